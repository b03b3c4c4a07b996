/*
 * Instructions per frame of the pose pipeline on Cortex-M4 under QEMU
 * (mps2-an386, -icount shift=7, CMSDK timer 0: boards/mps2/insn_counter.h).
 * Built and run by run.sh with two frames from gen_frames.c in flash; prints,
 * per frame, the status, the matches, and the instructions of pose_extract and
 * of the whole pose_process.
 */
#include <stdint.h>
#include <string.h>

#include "board.h"
#include "insn_counter.h"
#include "pose/pose.h"
#include "semihost.h"

extern const uint16_t frame0_gray[], frame0_range[], frame1_gray[], frame1_range[];

static struct pose_pipeline pipe;
static struct pose_result res;

static void say(const char *s) {
    semihost_write_stdout(s, strlen(s));
}

static void say_u64(const char *label, uint64_t v) {
    char digits[24];
    int n = 0;
    do {
        digits[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v != 0u && n < 23);
    char out[24];
    for (int i = 0; i < n; ++i) {
        out[i] = digits[n - 1 - i];
    }
    out[n] = '\0';
    say(label);
    say(out);
    say("\n");
}

void board_exit(int status) {
    semihost_exit(status);
    for (;;) {
    }
}

void board_fault(const char *what) {
    say("FAULT ");
    say(what);
    say("\n");
    semihost_exit(128);
    for (;;) {
    }
}

int main(void) {
    struct pose_config cfg;
    pose_config_default(&cfg);
    struct pose_camera cam;
    pose_camera_paper(&cam);
    if (pose_init(&pipe, &cfg, &cam, pose_paper_target, POSE_PAPER_TARGET_COUNT) != POSE_OK) {
        say("pose_init failed\n");
        return 1;
    }
    const uint16_t *gray[2] = {frame0_gray, frame1_gray};
    const uint16_t *range[2] = {frame0_range, frame1_range};
    insn_counter_start();
    for (int i = 0; i < 2; ++i) {
        struct pose_frame f = {gray[i], range[i], 320u, 240u, 320u};
        uint32_t t0 = insn_counter_ticks();
        int e1 = pose_extract(&pipe, &f, &res, NULL, NULL);
        uint32_t t1 = insn_counter_ticks();
        int e2 = pose_process(&pipe, &f, &res, NULL, NULL);
        uint32_t t2 = insn_counter_ticks();
        if (e1 != POSE_OK || e2 != POSE_OK) {
            say("pose error\n");
            return 1;
        }
        say_u64("frame ", (uint64_t)i);
        say("  status ");
        say(pose_status_name(res.status));
        say("\n");
        say_u64("  matches ", res.n_matches);
        say_u64("  t_z_um ", (uint64_t)(res.t_mm[2] * 1000.0f));
        say_u64("  active_pixels ", res.active_pixels);
        say_u64("  refine_iterations ", res.refine_iterations);
        say_u64("  insn_extract ", insn_counter_between(t0, t1));
        say_u64("  insn_process ", insn_counter_between(t1, t2));
    }
    return 0;
}
