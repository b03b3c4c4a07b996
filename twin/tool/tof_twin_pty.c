/* tof_twin --pty: USART2 on a pseudo-terminal a host program opens as it would a board's
 * serial port (tools/tof_telemetry.py --port PATH), with simulated time paced to the host's
 * clock while a line is open, as QEMU's and Renode's serial back ends run the guest in real
 * time (docs/reference/tools.md). */
#define _GNU_SOURCE /* posix_openpt, grantpt, unlockpt, ptsname; cfmakeraw and ppoll */

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "tof_twin.h"

/* The longest sleep while no line is open and the twin is paced: a line opened meanwhile is
 * seen within it. */
#define IDLE_SLEEP_NS 20000000ll
/* One slice of emulation between two polls is at most one SysTick period of the flight image
 * (1 ms): pacing keeps the simulated time at least that far behind the host's, so that even
 * inside a slice it is not ahead. */
#define SLICE_LEAD_PS 1000000000ull

static volatile sig_atomic_t stop_signal;

static void on_signal(int sig) {
    stop_signal = sig;
}

static int64_t host_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000ll + ts.tv_nsec;
}

int tof_twin_pty_open(struct run *r) {
    struct tof_twin_pty *p = &r->pty;
    p->fd = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    const char *path = NULL;
    if (p->fd < 0 || grantpt(p->fd) != 0 || unlockpt(p->fd) != 0 ||
        (path = ptsname(p->fd)) == NULL) {
        fprintf(stderr, "tof_twin: --pty: no pseudo-terminal: %s\n", strerror(errno));
        return -1;
    }
    snprintf(p->path, sizeof p->path, "%s", path);
    /* Raw bytes both ways, whoever opens the slave: the master's termios calls set the
     * slave's line discipline (no echo of the telemetry back into the commands, no CR/LF
     * translation, no canonical lines). 115200 Bd is what the board's port states. */
    struct termios tio;
    if (tcgetattr(p->fd, &tio) != 0) {
        fprintf(stderr, "tof_twin: --pty %s: %s\n", p->path, strerror(errno));
        return -1;
    }
    cfmakeraw(&tio);
    cfsetispeed(&tio, B115200);
    cfsetospeed(&tio, B115200);
    if (tcsetattr(p->fd, TCSANOW, &tio) != 0) {
        fprintf(stderr, "tof_twin: --pty %s: %s\n", p->path, strerror(errno));
        return -1;
    }
    /* A master whose slave was never opened does not report a hang-up (Linux): open and
     * close it once, so that "no line open" reads the same before the first user as after
     * the last one. */
    const int s = open(p->path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (s >= 0) {
        close(s);
    }
    tlm_decoder_init(&p->dec, tlm_message_types(TLM_ACCEPT_COMMANDS));
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    printf("pty %s\n", p->path);
    fflush(stdout);
    return 0;
}

void tof_twin_pty_close(struct run *r) {
    if (r->pty.fd >= 0) {
        close(r->pty.fd);
        r->pty.fd = -1;
    }
}

bool tof_twin_pty_stopped_by_signal(const struct run *r) {
    return r->pty.stop_signal != 0;
}

/* A command frame the host sent, decoded from the bytes as the firmware will see them: its
 * sequence number, type and when its last byte ends, for the ack latency. */
static void on_host_frame(void *ctx, const struct tlm_frame *frame) {
    struct run *r = ctx;
    struct tof_twin_pty *p = &r->pty;
    ++p->commands;
    if (p->npending == TOF_TWIN_PTY_PENDING) {
        /* the oldest is forgotten: a host that never waits for answers */
        memmove(&p->pending[0], &p->pending[1], sizeof p->pending[0] * (p->npending - 1u));
        --p->npending;
    }
    p->pending[p->npending++] = (struct pty_command){
        .seq = frame->seq, .type = frame->type, .last_byte_ps = p->byte_end_ps};
}

static void on_host_reject(void *ctx, const struct tlm_reject *reject) {
    (void)ctx;
    (void)reject;
}

bool tof_twin_pty_answer(struct run *r, const struct tlm_ack *ack) {
    struct tof_twin_pty *p = &r->pty;
    for (unsigned k = 0; k < p->npending; ++k) {
        if (p->pending[k].seq == ack->echo_seq && p->pending[k].type == ack->command) {
            const uint64_t lat = r->now_ps - p->pending[k].last_byte_ps;
            p->ack_latency_max_ps = lat > p->ack_latency_max_ps ? lat : p->ack_latency_max_ps;
            p->ack_latency_sum_ps += lat;
            ++p->answered;
            p->nacked += ack->result != 0u ? 1u : 0u;
            memmove(&p->pending[k], &p->pending[k + 1u],
                    sizeof p->pending[0] * (p->npending - k - 1u));
            --p->npending;
            return true;
        }
    }
    return false;
}

void tof_twin_pty_on_byte(struct run *r, uint8_t byte) {
    struct tof_twin_pty *p = &r->pty;
    if (!p->line_open) {
        ++p->unheard; /* nobody on the line: the bytes go nowhere, as on a board's */
        return;
    }
    if (p->out_len == sizeof p->out) {
        ++p->dropped;
        return;
    }
    p->out[p->out_len++] = byte;
}

/* The host's bytes into USART2's receiver, at the line rate from now. */
static void take_input(struct run *r) {
    struct tof_twin_pty *p = &r->pty;
    for (;;) {
        const size_t room = sizeof p->in - p->in_len;
        if (room > 0u) {
            const ssize_t n = read(p->fd, &p->in[p->in_len], room);
            if (n > 0) {
                p->in_len += (size_t)n;
            }
        }
        if (p->in_len == 0u) {
            return;
        }
        const unsigned free_q = TWIN_USART_RXQ - r->t.usart.rx_count;
        const unsigned len = p->in_len < free_q ? (unsigned)p->in_len : free_q;
        if (len == 0u) {
            return; /* the receiver's queue is full: the rest waits in p->in */
        }
        const uint64_t last = twin_usart_send_to_mcu(&r->t, p->in, len);
        const uint64_t byte_ps = 10u * 1000000000000ull / TWIN_HOST_BAUD;
        const struct tlm_frame_sink sink = {
            .on_frame = on_host_frame, .on_reject = on_host_reject, .ctx = r};
        for (unsigned i = 0; i < len; ++i) {
            p->byte_end_ps = last - (uint64_t)(len - 1u - i) * byte_ps;
            tlm_decoder_push(&p->dec, p->in[i], &sink);
        }
        p->bytes_in += len;
        memmove(p->in, &p->in[len], p->in_len - len);
        p->in_len -= len;
    }
}

/* The firmware's bytes to the host; what the slave's buffer cannot take is lost (a host
 * that does not read, as with a board's virtual COM port). */
static void give_output(struct run *r) {
    struct tof_twin_pty *p = &r->pty;
    size_t done = 0;
    while (done < p->out_len) {
        const ssize_t n = write(p->fd, &p->out[done], p->out_len - done);
        if (n <= 0) {
            p->dropped += p->out_len - done;
            break;
        }
        done += (size_t)n;
    }
    p->bytes_out += done;
    p->out_len = 0;
}

/* Sleep `ns`, or less if the host writes to the line meanwhile. */
static void wait_host(const struct tof_twin_pty *p, int64_t ns) {
    if (ns <= 0) {
        return;
    }
    struct timespec ts = {.tv_sec = ns / 1000000000ll, .tv_nsec = ns % 1000000000ll};
    if (p->line_open) {
        struct pollfd f = {.fd = p->fd, .events = POLLIN};
        (void)ppoll(&f, 1, &ts, NULL);
    } else {
        (void)nanosleep(&ts, NULL);
    }
}

void tof_twin_pty_poll(struct run *r) {
    struct tof_twin_pty *p = &r->pty;
    if (stop_signal != 0) {
        p->stop_signal = stop_signal;
        twin_stop(&r->t, TWIN_STOP_DONE, "stopped by signal %d", (int)stop_signal);
        return;
    }
    struct pollfd f = {.fd = p->fd, .events = POLLIN};
    (void)poll(&f, 1, 0);
    const bool open_now = (f.revents & POLLHUP) == 0;
    const uint64_t sim_ps = twin_now_ps(&r->t);
    if (open_now != p->line_open) {
        p->line_open = open_now;
        p->opens += open_now ? 1u : 0u;
        fprintf(stderr, "tof_twin: pty: line %s at %.3f s simulated\n",
                open_now ? "opened" : "closed", (double)sim_ps / 1e12);
        p->out_len = 0;
    }
    if (p->line_open) {
        take_input(r);
        give_output(r);
    }
    /* Paced while a line is open, and once the trace's first pass is over (nobody watching a
     * trace that loops: no point in running ahead); free otherwise. */
    const bool first_pass_over =
        r->w.origin_set &&
        twin_now_us(&r->t) >= r->w.origin_us + (uint64_t)r->row_count * r->w.period_us;
    const bool paced = p->line_open || first_pass_over;
    const int64_t now_ns = host_ns();
    if (paced && !p->paced) {
        p->anchor_host_ns = now_ns;
        p->anchor_sim_ps = sim_ps;
    }
    p->paced = paced;
    if (!paced) {
        return;
    }
    const int64_t sim_ns = (int64_t)((sim_ps - p->anchor_sim_ps + SLICE_LEAD_PS) / 1000u);
    int64_t ahead_ns = sim_ns - (now_ns - p->anchor_host_ns);
    if (ahead_ns > 0) {
        if (!p->line_open && ahead_ns > IDLE_SLEEP_NS) {
            ahead_ns = IDLE_SLEEP_NS;
        }
        p->slept_ns += ahead_ns;
        wait_host(p, ahead_ns);
        if (p->line_open) {
            take_input(r); /* what came while waiting, at the time it came */
        }
    } else if (-ahead_ns > p->behind_max_ns) {
        p->behind_max_ns = -ahead_ns;
    }
}
