/* Independent watchdog of the twin (RM0351 §32): keys, the write-protected prescaler and
 * reload, the update flags, and the counter that resets the core when it reaches 0. */
#include "twin.h"

#define IWDG_KR   0x00u
#define IWDG_PR   0x04u
#define IWDG_RLR  0x08u
#define IWDG_SR   0x0Cu
#define IWDG_WINR 0x10u

/* LSI nominal 32 kHz (DS10198 "LSI oscillator characteristics": 29.5..34 kHz); the counter
 * runs at LSI / (4 << PR) (RM0351 §32.3.2, Table "IWDG prescaler"). */
#define LSI_HZ 32000u
/* PVU/RVU/WVU stay set while the value crosses to the LSI domain: up to 5 LSI periods
 * (RM0351 §32.4.4). */
#define UPDATE_PS (5ull * 1000000000000ull / LSI_HZ)

static uint64_t timeout_ps(const struct twin_iwdg *w) {
    const uint64_t div = 4ull << (w->pr & 7u);
    return ((uint64_t)(w->rlr & 0xFFFu) + 1u) * div * (1000000000000ull / LSI_HZ);
}

void twin_iwdg_reset(struct twin *t) {
    const uint32_t kicks = t->iwdg.kicks;
    /* Software watchdog (option byte IWDG_SW = 1, the default): off after reset. */
    t->iwdg = (struct twin_iwdg){.rlr = 0xFFFu, .winr = 0xFFFu, .expire_ps = UINT64_MAX};
    t->iwdg.kicks = kicks;
}

uint64_t twin_iwdg_expiry(const struct twin *t) {
    /* DBGMCU DBG_IWDG_STOP only acts while a debugger halts the core: never here. */
    return t->iwdg.running ? t->iwdg.expire_ps : UINT64_MAX;
}

uint32_t twin_iwdg_read(struct twin *t, uint32_t off) {
    struct twin_iwdg *w = &t->iwdg;
    switch (off) {
    case IWDG_KR:
        return 0u;
    case IWDG_PR:
        return w->pr;
    case IWDG_RLR:
        return w->rlr;
    case IWDG_SR:
        if (w->sr != 0u) {
            if (twin_svc_now_ps(&t->svc) < w->update_done_ps) {
                twin_svc_warp_to(&t->svc, w->update_done_ps); /* an update poll */
            }
            if (twin_svc_now_ps(&t->svc) >= w->update_done_ps) {
                w->sr = 0u;
            }
        }
        return w->sr;
    case IWDG_WINR:
        return w->winr;
    default:
        twin_svc_violation(&t->svc, "IWDG register", off, "reserved IWDG offset (RM0351 §32.4.6)");
        return 0u;
    }
}

static void reload(struct twin *t) {
    t->iwdg.expire_ps = twin_svc_now_ps(&t->svc) + timeout_ps(&t->iwdg);
    t->iwdg.kicks++;
}

void twin_iwdg_write(struct twin *t, uint32_t off, uint32_t v) {
    struct twin_iwdg *w = &t->iwdg;
    switch (off) {
    case IWDG_KR:
        switch (v & 0xFFFFu) {
        case 0xCCCCu: /* start (and LSI on) */
            w->running = true;
            reload(t);
            break;
        case 0x5555u:
            w->unlocked = true;
            break;    /* PR, RLR, WINR writable */
        case 0xAAAAu: /* refresh; also write-protects again */
            w->unlocked = false;
            if (w->sr != 0u && twin_svc_now_ps(&t->svc) < w->update_done_ps) {
                twin_svc_violation(&t->svc, "IWDG_KR", v,
                                   "refresh while PVU/RVU are set: the old prescaler or reload is "
                                   "used (RM0351 §32.4.4)");
            }
            if (w->running) {
                reload(t);
            }
            break;
        default:
            w->unlocked = false;
            break;
        }
        break;
    case IWDG_PR:
    case IWDG_RLR:
    case IWDG_WINR:
        if (!w->unlocked) {
            twin_svc_violation(&t->svc, "IWDG_PR/RLR/WINR", v,
                               "written without the 0x5555 key: ignored (RM0351 §32.3.6)");
            break;
        }
        if (off == IWDG_PR) {
            w->pr = v & 7u;
            w->sr |= 1u;
        } else if (off == IWDG_RLR) {
            w->rlr = v & 0xFFFu;
            w->sr |= 2u;
        } else {
            w->winr = v & 0xFFFu;
            w->sr |= 4u;
        }
        w->update_done_ps = twin_svc_now_ps(&t->svc) + UPDATE_PS;
        break;
    default:
        twin_svc_violation(&t->svc, "IWDG register", off, "reserved IWDG offset (RM0351 §32.4.6)");
        break;
    }
}
