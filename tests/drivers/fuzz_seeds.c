/*
 * Writes the named seed corpora of the firmware's fuzz targets:
 *
 *   fuzz_seeds OUT_DIR   ->  OUT_DIR/fuzz_attitude/<name>.bin
 *                            OUT_DIR/fuzz_estimator_math/<name>.bin
 *                            OUT_DIR/fuzz_vl53/<name>.bin
 *
 * The estimator seeds are built field by field in each harness's input format.
 * The driver seeds are recorded: fz_vl53_run() is driven by a scripted source
 * whose bus, GPIO and data bytes come from a small VL53 device model (boot time,
 * address change, register file, timed measurements with stream counts, data
 * ready, XSHUT reset) with scripted faults, and every byte it hands out is
 * written down; the fuzzer replays the file through the same harness, so each
 * seed starts it deep in a real bring-up, ranging or recovery.
 *
 * The committed corpora (tests/estimator/corpus/fuzz_attitude, fuzz_estimator_math,
 * tests/drivers/corpus/fuzz_vl53) are exactly what this program writes:
 * unit.fuzz_seeds_current checks them. Regenerate after changing an input format:
 *   build/<dir>/tests/drivers/fuzz_seeds OUT, then copy OUT/<target>/ over each
 */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz_vl53_harness.h"
#include "vl53/vl53_regs.h"

/* --- output -------------------------------------------------------------------------------- */

#define SEED_MAX 65536u

struct buf {
    uint8_t data[SEED_MAX];
    size_t len;
};

static struct buf seed;
static const char *out_root;
static int failures;

static void put_u8(struct buf *b, unsigned v) {
    if (b->len >= SEED_MAX) {
        fprintf(stderr, "fuzz_seeds: a seed grew beyond %u bytes\n", SEED_MAX);
        exit(1);
    }
    b->data[b->len++] = (uint8_t)v;
}

static void put_u16(struct buf *b, unsigned v) {
    put_u8(b, v & 0xFFu);
    put_u8(b, (v >> 8) & 0xFFu);
}

static void put_u32(struct buf *b, uint32_t v) {
    put_u16(b, v & 0xFFFFu);
    put_u16(b, v >> 16);
}

static void put_u64(struct buf *b, uint64_t v) {
    put_u32(b, (uint32_t)v);
    put_u32(b, (uint32_t)(v >> 32));
}

static void make_dir(const char *path) {
    if (mkdir(path, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "fuzz_seeds: cannot create %s: %s\n", path, strerror(errno));
        exit(1);
    }
}

static void write_seed(const char *target, const char *name, const struct buf *b) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", out_root, target);
    make_dir(path);
    snprintf(path, sizeof path, "%s/%s/%s.bin", out_root, target, name);
    FILE *f = fopen(path, "wb");
    if (f == NULL || fwrite(b->data, 1, b->len, f) != b->len || fclose(f) != 0) {
        fprintf(stderr, "fuzz_seeds: cannot write %s\n", path);
        failures++;
    }
}

/* --- fuzz_attitude --------------------------------------------------------------------------- */

struct att_cfg {
    uint32_t arm_um;
    unsigned window;
    bool sliding;
    unsigned estimators;
    unsigned gate_q8;
    unsigned floor_mm;
    unsigned warmup;
    bool twins;       /* also run the twin state and compare */
    bool auto_q;      /* the Kalman filter's process_noise_auto (mode bit 1) */
    unsigned q_u16;   /* Q of each state, um^2 before the shift (0: Q = 0) */
    unsigned q_shift; /* ... shifted left by this (0..16) */
};

static const struct att_cfg att_default = {30000u, 100u, false, 15u, 1280u, 3u,
                                           5u,     true, false, 0u,  0u};

/* The guided configuration of fuzz_attitude.c, field by field (fuzz_range_u32 takes
 * lo + v % span: each v below is the wanted value minus lo). */
static void att_guided(struct buf *b, const struct att_cfg *c) {
    put_u8(b, (c->twins ? 0x80u : 0u) | (c->auto_q ? 2u : 0u)); /* guided */
    put_u32(b, c->arm_um - 1000u);                              /* arm: 4 bytes (span >= 2^16) */
    put_u8(b, c->window - 2u);                                  /* window 2..256: 1 byte */
    put_u8(b, c->sliding ? 1u : 0u);                            /* mode */
    put_u8(b, c->estimators - 1u);                              /* estimators 1..15 */
    put_u32(b, 1000u - 1u);                                     /* tolerance 1000 udeg */
    put_u16(b, 200u - 1u);                                      /* paper iterations */
    put_u16(b, 512u);                                           /* paper consistency 2 sigma */
    put_u16(b, c->gate_q8);                                     /* MAD gate */
    put_u8(b, c->floor_mm);                                     /* gate floor */
    put_u8(b, c->q_shift);                                      /* Q shift */
    for (unsigned i = 0; i < 3u; ++i) {
        put_u16(b, c->q_u16); /* Q (0: the static filter) */
    }
    for (unsigned k = 0; k < 4u; ++k) {
        put_u32(b, 4000000u); /* R = (2 mm)^2 */
    }
    put_u16(b, 1280u);         /* Kalman gate 5 sigma */
    put_u8(b, c->warmup - 1u); /* warm-up rows */
    put_u8(b, 2u);             /* noise shift */
}

/* A plate block of count (1..256) rows. */
static void att_plate(struct buf *b, unsigned count, unsigned d, int ta, int tb, unsigned amp,
                      unsigned faults, unsigned spikes, unsigned seed16) {
    put_u8(b, 1u);
    put_u8(b, count - 1u);
    put_u16(b, d);
    put_u8(b, (unsigned)(ta & 0xFF));
    put_u8(b, (unsigned)(tb & 0xFF));
    put_u8(b, amp);
    put_u8(b, faults);
    put_u8(b, spikes);
    put_u8(b, 1u); /* status of flagged readings */
    put_u16(b, seed16);
}

static void att_row(struct buf *b, const unsigned range[4], const unsigned status[4],
                    unsigned missing_mask) {
    put_u8(b, 0u);
    put_u8(b, 0u); /* count (unused by an explicit row) */
    for (unsigned k = 0; k < 4u; ++k) {
        put_u16(b, range[k]);
        put_u8(b, status[k]);
    }
    put_u8(b, missing_mask);
}

static void att_repeat(struct buf *b, unsigned times_minus_1, unsigned count) {
    put_u8(b, 2u | (times_minus_1 << 2));
    put_u8(b, count - 1u);
}

static void att_gap(struct buf *b, unsigned missing_mask, unsigned count) {
    put_u8(b, 3u | (missing_mask << 4));
    put_u8(b, count - 1u);
}

static void attitude_seeds(void) {
    static const unsigned ok[4] = {0, 0, 0, 0};
    struct att_cfg c;

    seed.len = 0; /* the product defaults, a tilted plate, two windows */
    att_guided(&seed, &att_default);
    att_plate(&seed, 100u, 500u, 5, -3, 2u, 0u, 0u, 1u);
    att_plate(&seed, 100u, 500u, 5, -3, 2u, 0u, 0u, 2u);
    write_seed("fuzz_attitude", "tumbling_plate", &seed);

    seed.len = 0; /* sliding window over flagged, missing and spiky readings */
    c = att_default;
    c.window = 20u;
    c.sliding = true;
    att_guided(&seed, &c);
    att_plate(&seed, 60u, 300u, -8, 4, 3u, 0x12u, 0x04u, 3u);
    write_seed("fuzz_attitude", "sliding_flagged_spikes", &seed);

    seed.len = 0; /* N identical rows: the exact answers are known */
    c = att_default;
    c.window = 10u;
    att_guided(&seed, &c);
    att_row(&seed, (const unsigned[4]){480u, 505u, 520u, 495u}, ok, 0u);
    att_repeat(&seed, 0u, 29u);
    write_seed("fuzz_attitude", "constant_rows", &seed);

    seed.len = 0; /* a sensor drops out for a window and more */
    c = att_default;
    c.window = 50u;
    c.twins = false;
    att_guided(&seed, &c);
    att_plate(&seed, 50u, 800u, 2, 2, 1u, 0u, 0u, 4u);
    att_gap(&seed, 0x4u, 60u);
    att_plate(&seed, 50u, 800u, 2, 2, 1u, 0u, 0u, 5u);
    write_seed("fuzz_attitude", "sensor_gap", &seed);

    seed.len = 0; /* readings 0 and 65535 in one window, gate off: the noise extremes */
    c = att_default;
    c.window = 2u;
    c.gate_q8 = 0u;
    att_guided(&seed, &c);
    att_row(&seed, (const unsigned[4]){0u, 0u, 0u, 0u}, ok, 0u);
    att_row(&seed, (const unsigned[4]){65535u, 65535u, 65535u, 65535u}, ok, 0u);
    att_plate(&seed, 20u, 1000u, 0, 0, 1u, 0u, 0u, 6u);
    write_seed("fuzz_attitude", "extreme_ranges", &seed);

    seed.len = 0; /* Kalman alone with the longest warm-up and a short window */
    c = att_default;
    c.window = 4u;
    c.estimators = 4u;
    c.warmup = 8u;
    att_guided(&seed, &c);
    att_plate(&seed, 40u, 200u, 10, -10, 4u, 0x01u, 0x08u, 7u);
    write_seed("fuzz_attitude", "kalman_warmup", &seed);

    seed.len = 0; /* `auto` on a plate that tilts block by block, tumbling */
    c = att_default;
    c.window = 20u;
    c.estimators = 5u; /* the flight set: consensus and Kalman */
    c.auto_q = true;
    att_guided(&seed, &c);
    for (int step = 0; step < 6; ++step) {
        att_plate(&seed, 20u, 600u + 3u * (unsigned)step, -10 + 4 * step, 6 - 2 * step, 3u, 0u, 0u,
                  9u + (unsigned)step);
    }
    write_seed("fuzz_attitude", "auto_tumbling_tilt", &seed);

    seed.len = 0; /* `auto`, sliding, over flagged, missing and spiky readings and a gap */
    c = att_default;
    c.window = 16u;
    c.sliding = true;
    c.auto_q = true;
    c.twins = false;
    att_guided(&seed, &c);
    att_plate(&seed, 40u, 350u, 4, -4, 5u, 0x21u, 0x02u, 15u);
    att_gap(&seed, 0x8u, 10u);
    att_plate(&seed, 40u, 360u, 12, -2, 5u, 0x21u, 0x02u, 16u);
    write_seed("fuzz_attitude", "auto_sliding_faults", &seed);

    seed.len = 0; /* a fixed Q > 0 (1000 um^2 << 4 per row) on a tilting plate */
    c = att_default;
    c.window = 25u;
    c.q_u16 = 1000u;
    c.q_shift = 4u;
    att_guided(&seed, &c);
    att_plate(&seed, 50u, 450u, -6, 2, 2u, 0u, 0u, 17u);
    att_plate(&seed, 50u, 452u, 6, -2, 2u, 0u, 0u, 18u);
    write_seed("fuzz_attitude", "fixed_q_tilt", &seed);

    seed.len = 0; /* a raw configuration that is valid */
    put_u8(&seed, 1u);
    put_u32(&seed, 30000u); /* arm */
    put_u16(&seed, 16u);    /* window */
    put_u8(&seed, 1u);      /* sliding */
    put_u8(&seed, 0x0Fu);   /* estimators */
    put_u32(&seed, 1000u);  /* tolerance */
    put_u16(&seed, 200u);   /* paper iterations */
    put_u16(&seed, 512u);   /* consistency */
    put_u16(&seed, 1280u);  /* gate */
    put_u16(&seed, 3u);     /* floor */
    for (unsigned i = 0; i < 3u; ++i) {
        put_u32(&seed, 100u); /* Q */
    }
    for (unsigned k = 0; k < 4u; ++k) {
        put_u32(&seed, 4000000u); /* R */
    }
    put_u16(&seed, 1280u); /* Kalman gate */
    put_u8(&seed, 5u);     /* warm-up */
    put_u8(&seed, 2u);     /* shift */
    att_plate(&seed, 40u, 400u, 3, 1, 2u, 0u, 0u, 8u);
    write_seed("fuzz_attitude", "raw_valid_config", &seed);

    seed.len = 0; /* a raw configuration with a bad arm (and more) */
    put_u8(&seed, 1u);
    put_u32(&seed, 999u);
    put_u16(&seed, 1u);
    write_seed("fuzz_attitude", "raw_invalid_config", &seed);
}

/* --- fuzz_estimator_math ----------------------------------------------------------------- */

static void math_seeds(void) {
    seed.len = 0; /* every scalar helper once, on interesting operands */
    for (unsigned which = 0; which < 12u; ++which) {
        put_u8(&seed, 0u);
        put_u8(&seed, which);
        put_u64(&seed, which % 2u == 0u ? (uint64_t)INT64_MIN : 0x0000000123456789u);
        put_u64(&seed, which % 3u == 0u ? UINT64_MAX : 3u);
        put_u8(&seed, 31u + which);
        if (which >= 8u) { /* the 128-bit operands */
            put_u64(&seed, 0x8000000000000001u);
            put_u64(&seed, 0x0123456789ABCDEFu);
            put_u64(&seed, 0x3FFFFFFFFFFFFFFFu);
            put_u64(&seed, 0xFFFFFFFFFFFFFFFFu);
            if (which == 10u) {
                put_u64(&seed, 7u); /* muldiv denominator */
            }
        }
    }
    write_seed("fuzz_estimator_math", "fixmath_scalar", &seed);

    seed.len = 0; /* atan2 near the axes and the diagonal, atan, delta-method sigma */
    for (unsigned which = 0; which < 3u; ++which) {
        put_u8(&seed, 1u);
        put_u8(&seed, which);
        put_u64(&seed, 0x7FFFFFFFFFFFFFFFu);
        put_u8(&seed, 20u);
        put_u64(&seed, 0x7FFFFFFFFFFFFF00u);
        put_u8(&seed, 20u + which);
        if (which == 2u) {
            put_u64(&seed, 1u << 30);
            put_u8(&seed, 0u);
        }
    }
    write_seed("fuzz_estimator_math", "atan", &seed);

    seed.len = 0; /* the ten angles of a tilted sample, all sensors */
    put_u8(&seed, 2u);
    put_u16(&seed, 480u);
    put_u16(&seed, 505u);
    put_u16(&seed, 520u);
    put_u16(&seed, 495u);
    put_u8(&seed, 0x0Fu);
    put_u32(&seed, 30000u - 1000u);
    put_u8(&seed, 2u); /* and with D missing */
    put_u16(&seed, 0u);
    put_u16(&seed, 65535u);
    put_u16(&seed, 1u);
    put_u16(&seed, 7u);
    put_u8(&seed, 0x07u);
    put_u32(&seed, 0u);
    write_seed("fuzz_estimator_math", "angles", &seed);

    seed.len = 0; /* product consensus: all four sensors, then B missing */
    for (unsigned round = 0; round < 2u; ++round) {
        put_u8(&seed, 3u);
        put_u8(&seed, round == 0u ? 0x0Fu : 0x0Du);
        for (unsigned k = 0; k < 4u; ++k) {
            put_u16(&seed, 99u);                                /* count 100 */
            put_u64(&seed, ((uint64_t)(500u + 10u * k)) << 32); /* mean */
            put_u64(&seed, (uint64_t)(4u + k) << 32);           /* variance */
            put_u8(&seed, 0u);                                  /* no extra shift */
        }
        put_u32(&seed, 30000u - 1000u);
        put_u32(&seed, 1000u - 1u);
    }
    write_seed("fuzz_estimator_math", "consensus_product", &seed);

    seed.len = 0; /* paper consensus on a symmetric covariance of a real-looking window */
    put_u8(&seed, 4u);
    for (unsigned i = 0; i < 5u; ++i) {
        put_u64(&seed, ((uint64_t)(180000000u + 1000000u + 1000u * i)) << 16);
    }
    put_u8(&seed, 1u); /* symmetric */
    for (unsigned i = 0; i < 5u; ++i) {
        for (unsigned j = i; j < 5u; ++j) {
            put_u64(&seed, i == j ? 40000000u : (uint64_t)(int64_t)(i + j) * 100000u);
            put_u8(&seed, 0u);
        }
    }
    put_u16(&seed, 100u);
    put_u32(&seed, 1000u - 1u);
    put_u16(&seed, 200u);
    write_seed("fuzz_estimator_math", "consensus_paper", &seed);

    seed.len = 0; /* Kalman: a valid configuration, rows, flush, tracking, estimate */
    put_u8(&seed, 5u);
    put_u8(&seed, 1u); /* guided */
    for (unsigned i = 0; i < 3u; ++i) {
        put_u64(&seed, 1u << 20);
        put_u8(&seed, 0u);
    }
    for (unsigned k = 0; k < 4u; ++k) {
        put_u64(&seed, (uint64_t)4u << 32);
        put_u8(&seed, 0u);
    }
    put_u16(&seed, 1280u);
    put_u16(&seed, 3u);
    put_u8(&seed, 4u); /* warm-up 5 */
    put_u8(&seed, 2u);
    for (unsigned r = 0; r < 8u; ++r) {
        put_u8(&seed, 0u); /* push a row */
        put_u16(&seed, 480u + r % 3u);
        put_u16(&seed, 505u);
        put_u16(&seed, 520u - r % 2u);
        put_u16(&seed, 495u);
        put_u8(&seed, r == 6u ? 0x0Bu : 0x0Fu);
    }
    put_u8(&seed, 1u); /* a long outage: 200 rows with no valid reading */
    put_u16(&seed, 0u);
    put_u16(&seed, 0u);
    put_u16(&seed, 0u);
    put_u16(&seed, 0u);
    put_u8(&seed, 0u);
    put_u8(&seed, 199u);
    put_u8(&seed, 2u); /* flush */
    put_u8(&seed, 4u); /* track noise of sensor 1 */
    put_u8(&seed, 1u);
    put_u64(&seed, (uint64_t)9u << 32);
    put_u8(&seed, 0u);
    put_u16(&seed, 100u);
    put_u8(&seed, 0x83u); /* a gated update */
    put_u8(&seed, 2u);
    put_u64(&seed, (uint64_t)521u << 32);
    put_u8(&seed, 34u);
    put_u8(&seed, 0x85u); /* estimate, then reset */
    put_u32(&seed, 30000u - 1000u);
    write_seed("fuzz_estimator_math", "kalman", &seed);

    seed.len = 0; /* Kalman with process_noise_auto (style bit 2): a plate tilting row by row */
    put_u8(&seed, 5u);
    put_u8(&seed, 5u); /* guided, auto */
    for (unsigned i = 0; i < 3u; ++i) {
        put_u64(&seed, 0u); /* Q = 0 to start from */
        put_u8(&seed, 0u);
    }
    for (unsigned k = 0; k < 4u; ++k) {
        put_u64(&seed, (uint64_t)4u << 32);
        put_u8(&seed, 0u);
    }
    put_u16(&seed, 1280u);
    put_u16(&seed, 3u);
    put_u8(&seed, 4u); /* warm-up 5 */
    put_u8(&seed, 2u);
    for (unsigned r = 0; r < 56u; ++r) { /* α ramps: x_C − x_A grows 1 mm every 4 rows */
        put_u8(&seed, 0u);
        put_u16(&seed, 480u - r / 8u + (r * 7u) % 3u);
        put_u16(&seed, 505u + (r * 5u) % 3u);
        put_u16(&seed, 520u + r / 8u - (r * 3u) % 2u);
        put_u16(&seed, 495u + (r * 11u) % 3u);
        put_u8(&seed, r == 30u ? 0x07u : 0x0Fu);
    }
    put_u8(&seed, 2u); /* flush */
    put_u8(&seed, 4u); /* track noise: ignored with auto */
    put_u8(&seed, 0u);
    put_u64(&seed, (uint64_t)9u << 32);
    put_u8(&seed, 0u);
    put_u16(&seed, 100u);
    put_u8(&seed, 0x05u); /* estimate */
    put_u32(&seed, 30000u - 1000u);
    write_seed("fuzz_estimator_math", "kalman_auto", &seed);
}

/* --- fuzz_vl53: a scripted device model ------------------------------------------------------- */

#define DEV_MAX 4u

struct model_dev {
    bool present;
    bool out_of_reset;
    uint64_t power_up_us;
    uint8_t address;
    uint16_t model_id;
    uint8_t regs[0x200];
    bool ranging;
    uint64_t start_us;
    uint32_t cleared; /* measurements completed when the interrupt was last cleared */
};

struct model {
    /* the scenario */
    const uint8_t *script; /* configuration, operation and argument bytes, in order */
    size_t script_len;
    size_t script_pos;
    bool absent[DEV_MAX];
    uint16_t model_id[DEV_MAX];
    unsigned stuck_transfers; /* the first N transfers find SDA stuck */
    uint64_t nack_from_us;    /* every transfer in [from, until) is NACKed */
    uint64_t nack_until_us;
    uint64_t stale_from_us; /* measurements stop from here on (0: never) */
    /* derived from the script's configuration */
    bool active_low;
    uint32_t budget_us;
    uint32_t period_us;
    /* state */
    struct model_dev dev[DEV_MAX];
    uint8_t pending[64]; /* the bytes of the read in progress */
    struct buf *out;
};

static struct model m;

static void dev_reset(struct model_dev *d) {
    d->address = VL53_DEFAULT_ADDRESS;
    memset(d->regs, 0, sizeof d->regs);
    d->regs[VL53_REG_RESULT_OSC_CALIBRATE_VAL] = 0x01u; /* 0x00DE..DF: PLL period 0x0100 */
    d->regs[VL53_REG_RESULT_OSC_CALIBRATE_VAL + 1u] = 0x00u;
    d->regs[VL53_REG_GPIO_HV_MUX_CTRL] = 0x11u; /* the part's reset value: active low */
    d->ranging = false;
    d->cleared = 0;
}

/* Measurements completed by `now`: the first one budget after the start, then one per period. */
static uint32_t completed(const struct model_dev *d, uint64_t now) {
    if (!d->ranging || now < d->start_us + m.budget_us) {
        return 0u;
    }
    uint64_t t = now;
    if (m.stale_from_us != 0u && t > m.stale_from_us) {
        t = m.stale_from_us;
    }
    if (t < d->start_us + m.budget_us) {
        return 0u;
    }
    return 1u + (uint32_t)((t - d->start_us - m.budget_us) / m.period_us);
}

/* RESULT__STREAM_COUNT of measurement k (0-based): 0, 1, ... 255, then 128..255 again. */
static uint8_t stream_count(uint32_t k) {
    return (uint8_t)(k < 256u ? k : 128u + (k - 256u) % 128u);
}

static struct model_dev *dev_at(uint8_t addr7, uint64_t now) {
    for (unsigned i = 0; i < DEV_MAX; ++i) {
        struct model_dev *d = &m.dev[i];
        /* I²C answers about 1 ms after XSHUT rises ([DS] boot: 1.2 ms to "booted") */
        if (d->present && d->out_of_reset && d->address == addr7 && now >= d->power_up_us + 1000u) {
            return d;
        }
    }
    return NULL;
}

static bool data_ready(const struct model_dev *d, uint64_t now) {
    return completed(d, now) > d->cleared;
}

static uint8_t read_reg(const struct model_dev *d, uint16_t reg, uint64_t now) {
    const uint32_t n = completed(d, now);
    const uint32_t k = n > 0u ? n - 1u : 0u;
    const unsigned index = (unsigned)(d - m.dev);
    const uint16_t distance = (uint16_t)(100u + 10u * index + k % 50u);
    switch (reg) {
    case VL53_REG_FIRMWARE_SYSTEM_STATUS:
        return now >= d->power_up_us + 1200u ? VL53_FIRMWARE_BOOTED_BIT : 0u;
    case VL53_REG_IDENTIFICATION_MODEL_ID:
        return (uint8_t)(d->model_id >> 8);
    case VL53_REG_IDENTIFICATION_MODEL_ID + 1u:
        return (uint8_t)d->model_id;
    case VL53_REG_GPIO_TIO_HV_STATUS: {
        const bool active_low = (d->regs[VL53_REG_GPIO_HV_MUX_CTRL] & 0x10u) != 0u;
        return (uint8_t)(data_ready(d, now) != active_low ? 1u : 0u);
    }
    case VL53_REG_RESULT_RANGE_STATUS:
        return n > 0u ? 9u : 0u; /* raw 9: ULD status 0, valid */
    case VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_OFS_STREAM_COUNT:
        return stream_count(k);
    case VL53_REG_RESULT_DISTANCE:
        return (uint8_t)(distance >> 8);
    case VL53_REG_RESULT_DISTANCE + 1u:
        return (uint8_t)distance;
    default:
        return reg < sizeof d->regs ? d->regs[reg] : 0u;
    }
}

static void write_reg(struct model_dev *d, uint16_t reg, uint8_t value, uint64_t now) {
    if (reg < sizeof d->regs) {
        d->regs[reg] = value;
    }
    if (reg == VL53_REG_I2C_SLAVE_DEVICE_ADDRESS) {
        d->address = (uint8_t)(value & 0x7Fu);
    } else if (reg == VL53_REG_SYSTEM_MODE_START) {
        d->ranging = value == VL53_MODE_START_TIMED;
        d->start_us = now;
        d->cleared = 0;
    } else if (reg == VL53_REG_SYSTEM_INTERRUPT_CLEAR) {
        d->cleared = completed(d, now);
    }
}

static uint8_t model_bus(const struct fz_request *req) {
    if (req->recover) {
        return 0u; /* SDA released */
    }
    if (m.stuck_transfers > 0u) {
        m.stuck_transfers--;
        return FZ_BUS_STUCK;
    }
    if (req->now_us >= m.nack_from_us && req->now_us < m.nack_until_us) {
        return FZ_BUS_ADDR_NACK;
    }
    struct model_dev *d = dev_at(req->addr7, req->now_us);
    if (d == NULL || req->tx_len < 2u) {
        return FZ_BUS_ADDR_NACK;
    }
    const uint16_t reg = (uint16_t)(req->tx[0] << 8 | req->tx[1]);
    if (req->rx_len == 0u) {
        for (size_t i = 2u; i < req->tx_len; ++i) {
            write_reg(d, (uint16_t)(reg + i - 2u), req->tx[i], req->now_us);
        }
    } else {
        for (size_t i = 0; i < req->rx_len && i < sizeof m.pending; ++i) {
            m.pending[i] = read_reg(d, (uint16_t)(reg + i), req->now_us);
        }
    }
    return FZ_BUS_OK | FZ_BUS_DURATION(0u);
}

static uint8_t model_gpio(const struct fz_request *req) {
    if (req->pin < DEV_MAX) { /* XSHUT */
        struct model_dev *d = &m.dev[req->pin];
        if (req->gpio_write) {
            if (req->gpio_level && !d->out_of_reset) {
                dev_reset(d);
                d->power_up_us = req->now_us;
            }
            if (!req->gpio_level) {
                dev_reset(d);
            }
            d->out_of_reset = req->gpio_level;
        }
        return 0u;
    }
    const struct model_dev *d = &m.dev[(req->pin - DEV_MAX) % DEV_MAX]; /* GPIO1 */
    const bool active_low = (d->regs[VL53_REG_GPIO_HV_MUX_CTRL] & 0x10u) != 0u;
    return (uint8_t)(data_ready(d, req->now_us) != active_low ? 1u : 0u);
}

static uint8_t model_next(void *ctx, enum fz_kind kind, const struct fz_request *req) {
    (void)ctx;
    uint8_t byte = 0;
    switch (kind) {
    case FZ_CONFIG:
    case FZ_OP:
    case FZ_ARG:
        byte = m.script_pos < m.script_len ? m.script[m.script_pos++] : 0u;
        break;
    case FZ_BUS:
        byte = model_bus(req);
        break;
    case FZ_DATA:
        byte = req->rx_index < sizeof m.pending ? m.pending[req->rx_index] : 0u;
        break;
    default:
        byte = model_gpio(req);
        break;
    }
    put_u8(m.out, byte);
    return byte;
}

static bool model_done(void *ctx) {
    (void)ctx;
    return m.script_pos >= m.script_len;
}

/* Timings as fuzz_vl53_harness.c lists them: index -> (budget, period) in ms. */
static const unsigned harness_timings[][2] = {
    {15, 20}, {20, 24},  {33, 50}, {50, 54},   {100, 200},  {200, 204}, {500, 10000},
    {20, 24}, {33, 100}, {50, 54}, {100, 104}, {200, 1000}, {500, 504}, {15, 10000},
};

static void vl53_seed(const char *name, const uint8_t *script, size_t len) {
    const struct model keep = m; /* the scenario set by the caller */
    memset(&m, 0, sizeof m);
    m.script = script;
    m.script_len = len;
    memcpy(m.absent, keep.absent, sizeof m.absent);
    memcpy(m.model_id, keep.model_id, sizeof m.model_id);
    m.stuck_transfers = keep.stuck_transfers;
    m.nack_from_us = keep.nack_from_us;
    m.nack_until_us = keep.nack_until_us;
    m.stale_from_us = keep.stale_from_us;
    const unsigned timing = script[6] % (sizeof harness_timings / sizeof harness_timings[0]);
    m.budget_us = harness_timings[timing][0] * 1000u;
    m.period_us = harness_timings[timing][1] * 1000u;
    for (unsigned i = 0; i < DEV_MAX; ++i) {
        m.dev[i].present = !m.absent[i];
        m.dev[i].model_id = m.model_id[i] != 0u ? m.model_id[i] : VL53_MODEL_ID_VL53L1X;
        dev_reset(&m.dev[i]);
    }
    seed.len = 0;
    m.out = &seed;
    const struct fz_source src = {model_next, model_done, NULL};
    fz_vl53_run(&src);
    write_seed("fuzz_vl53", name, &seed);
    memset(&m, 0, sizeof m); /* the next scenario starts clean */
}

#define SCRIPT(name, ...)                                                                          \
    do {                                                                                           \
        static const uint8_t s_[] = {__VA_ARGS__};                                                 \
        vl53_seed(name, s_, sizeof s_);                                                            \
    } while (0)

/* Configuration bytes: sensors-1, origin (4), flags, timing, call, configure, i2c, poll. */
static void vl53_seeds(void) {
    SCRIPT("bring_up_4_poll", 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, /* 4 sensors, 15/20 ms */
           FZ_OP_BRING_UP, FZ_OP_POLL_LOOP, 99, 4);
    SCRIPT("gpio1_verify_vendor", 0, 0, 0, 0, 0, FZ_CFG_GPIO1 | FZ_CFG_VERIFY | FZ_CFG_VENDOR, 0, 0,
           0, 0, 0, FZ_OP_BRING_UP, FZ_OP_POLL_LOOP, 49, 9);
    SCRIPT("active_low_long_mode", 1, 0, 0, 0, 0, FZ_CFG_ACTIVE_LOW, 8, 4, 3, 3, 2, FZ_OP_BRING_UP,
           FZ_OP_POLL_LOOP, 59, 19);
    SCRIPT("clock_wrap", 3, 0x00, 0x00, 0xFF, 0xFF, 0, 0, 0, 0, 0, 0, /* 65 ms before the wrap */
           FZ_OP_BRING_UP, FZ_OP_POLL_LOOP, 99, 4);
    SCRIPT("direct_driver_calls", 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, FZ_OP_BRING_UP, FZ_OP_STOP, 0,
           FZ_OP_SET_TIMING, 0, 0, 2, FZ_OP_SET_TIMING, 1, 0, 2, FZ_OP_SET_TIMING, 2, 0, 11,
           FZ_OP_SET_TIMING, 3, 0, 2, FZ_OP_SET_TIMING, 0x80, 0, 0, FZ_OP_CONFIGURE, 0, FZ_OP_START,
           0, FZ_OP_SLEEP, 0x80 | 30, FZ_OP_DATA_READY, 0, FZ_OP_READ_RESULT, 0, FZ_OP_CLEAR_IRQ, 0,
           FZ_OP_SLEEP, 0x80 | 30, FZ_OP_POLL, 0, FZ_OP_IDENTIFY, 0, FZ_OP_GPIO1_READY, 0,
           FZ_OP_SET_ADDRESS, 0, 0x40, FZ_OP_SET_ADDRESS, 0, 0x05, FZ_OP_WAIT_BOOT, 0, FZ_OP_POWER,
           0, 0, FZ_OP_POWER, 0, 1, FZ_OP_WAIT_BOOT, 0, FZ_OP_IDENTIFY, 0, FZ_OP_RECOVER_BUS,
           FZ_OP_RECOVER_SENSOR, 0, FZ_OP_RECOVER_SENSOR, 1, FZ_OP_POLL_LOOP, 9, 19);
    SCRIPT("long_sleep_recover", 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, FZ_OP_BRING_UP, FZ_OP_POLL_LOOP,
           9, 9, FZ_OP_LONG_SLEEP, 0x00, 0x00, 0x00, 0x90, FZ_OP_POLL, 0, FZ_OP_POLL, 1,
           FZ_OP_WAIT_BOOT, 0, FZ_OP_RECOVER_SENSOR, 0, FZ_OP_POLL_LOOP, 9, 9);
    SCRIPT("bad_config", 2, 0, 0, 0, 0, FZ_CFG_BAD_CONFIG, 0, 0, 0, 0, 0, FZ_OP_BRING_UP);

    m.absent[2] = true;
    SCRIPT("missing_sensor", 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, FZ_OP_BRING_UP, FZ_OP_RECOVER_SENSOR,
           2, FZ_OP_POLL_LOOP, 49, 4);
    m.model_id[1] = 0xEACDu;
    SCRIPT("wrong_id", 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, FZ_OP_BRING_UP, FZ_OP_POLL_LOOP, 19, 4);
    m.stuck_transfers = 1u;
    SCRIPT("stuck_bus_then_recovered", 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, FZ_OP_BRING_UP,
           FZ_OP_POLL_LOOP, 29, 4);
    m.stuck_transfers = 1u;
    SCRIPT("stuck_bus_no_recover_hook", 1, 0, 0, 0, 0, FZ_CFG_NO_RECOVER, 0, 0, 0, 0, 0,
           FZ_OP_BRING_UP, FZ_OP_RECOVER_BUS, FZ_OP_BRING_UP, FZ_OP_POLL_LOOP, 9, 4);
    m.nack_from_us = 200000u;
    m.nack_until_us = 240000u;
    SCRIPT("nack_burst_then_recovery", 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, FZ_OP_BRING_UP,
           FZ_OP_POLL_LOOP, 99, 4, FZ_OP_RECOVER_SENSOR, 1, FZ_OP_POLL_LOOP, 19, 4);
    m.stale_from_us = 150000u;
    SCRIPT("sensor_stops_measuring", 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, FZ_OP_BRING_UP,
           FZ_OP_POLL_LOOP, 59, 4, FZ_OP_RECOVER_SENSOR, 0, FZ_OP_POLL_LOOP, 9, 4);
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s OUT_DIR  (writes OUT_DIR/<target>/<seed>.bin)\n", argv[0]);
        return 2;
    }
    out_root = argv[1];
    make_dir(out_root);
    attitude_seeds();
    math_seeds();
    vl53_seeds();
    return failures == 0 ? 0 : 1;
}
