/*
 * Named, seeded scenario generators: a plate at known attitude seen through
 * the noise models, one struct scene_row per sample, streamed (no limit on
 * length, nothing held but the generator). Scenarios and their parameters are
 * documented in docs/reference/trace-format.md.
 */
#ifndef SCENE_SCENARIO_H
#define SCENE_SCENARIO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "scene/noise.h"
#include "scene/real_noise.h"
#include "scene/rng.h"
#include "scene/row.h"
#include "scene/thermal.h"

/* Defaults shared by every named scenario (docs/reference/trace-format.md explains the choice). */
#define SCENE_DEFAULT_ARM_MM    30.0 /* a: fits paper Table I (see docs/reference/trace-format.md) */
#define SCENE_DEFAULT_MEAN_MM   100.0 /* x̄ */
#define SCENE_DEFAULT_PERIOD_MS 20u   /* 50 Hz, the 20 ms timing budget */
#define SCENE_DEFAULT_WINDOW    100u  /* N samples per position (paper Sec. IV) */
#define SCENE_MAX_LIST          16u
#define SCENE_NAME_MAX          32u

enum scene_schedule {
    SCENE_SCHEDULE_SWEEP, /* n_positions angles evenly from alpha_from to alpha_to inclusive */
    SCENE_SCHEDULE_LIST,  /* alpha_list_deg[0..n_positions) */
    SCENE_SCHEDULE_DEMO,  /* the fixed α/β steps-and-ramps schedule of the demo trace */
};

struct scene_config {
    char name[SCENE_NAME_MAX];
    double arm_mm;      /* a */
    double mean_mm;     /* x̄ */
    uint32_t period_ms; /* t_ms step between rows */
    enum scene_schedule schedule;
    uint32_t n_positions;                  /* SWEEP/LIST: attitudes; DEMO: ignored */
    uint32_t samples_per_position;         /* N: rows per position; also the dropout window */
    double alpha_from_deg, alpha_to_deg;   /* SWEEP */
    double alpha_list_deg[SCENE_MAX_LIST]; /* LIST */
    double beta_deg;                       /* β of every position ... */
    double beta_random_deg;                /* ... or, if > 0, β uniform in ±this per position */
    struct scene_sensor_noise noise[SCENE_SENSORS];
    double window_dropout_prob; /* P(one random sensor has no reading for a whole window) */
    bool real_noise;            /* noise from the shared recording instead of Gaussian */
    /* thermal.on: each part's offset follows the head's temperature and walks (scene/thermal.h);
     * the rows carry the measured temperature (temp_c) */
    struct scene_thermal thermal;
};

/* Extra truth about a generated row, for benchmarks (not stored in traces). */
struct scene_row_info {
    uint32_t position;              /* index of the attitude / window */
    double ideal_mm[SCENE_SENSORS]; /* noise-free distances */
    double sigma_mm[SCENE_SENSORS]; /* true std of this reading's noise incl. quantisation */
    /* std of the slow part of the noise, which acts as an offset constant over a
     * window (real noise only, else 0; see scene_crb_with_offset) */
    double offset_sd_mm[SCENE_SENSORS];
    bool outlier[SCENE_SENSORS];             /* a gross outlier was added (status 0) */
    double thermal_offset_mm[SCENE_SENSORS]; /* thermal scenarios: each part's whole offset */
    double temp_true_c;                      /* thermal scenarios: the head's true temperature */
};

struct scene_gen {
    struct scene_config cfg;
    uint64_t seed;
    uint64_t total_rows;
    uint64_t row;                /* next row index */
    struct scene_rng window_rng; /* per-window draws: β, dropout */
    struct scene_rng sensor_rng[SCENE_SENSORS];
    struct scene_rng dither_rng;         /* real noise: subtractive dither */
    double cur_beta_deg;                 /* β of the current window */
    int missing_sensor;                  /* sensor missing in this window, or -1 */
    struct scene_real_noise real_owned;  /* recording loaded by scene_gen_init */
    const struct scene_real_noise *real; /* recording in use (real_noise only) */
    struct scene_real_stretch stretch[SCENE_SENSORS];
    double offset_sd_mm[SCENE_SENSORS]; /* scene_real_stretch_offset_sd of each stretch */
    struct scene_thermal_head thermal;  /* cfg.thermal.on: the drawn head and its walks */
    char err[256];                      /* last failure of scene_gen_next */
};

/* Names of the built-in scenarios, NULL-terminated: table1, table2, hetero,
 * crossaxis, outliers, flagged, dropout, realnoise, realnoise-demo, orbit-thermal. */
extern const char *const scene_scenario_names[];

/* Fills cfg with the named scenario's parameters. Returns 0, or -1 if unknown. */
int scene_config_named(const char *name, struct scene_config *cfg);

/* The orbit-thermal scenario's length by default: four orbits of 90 minutes. */
#define SCENE_THERMAL_HOURS 6.0

/* Sets a SWEEP or LIST configuration's length to `hours` (rounded up to whole windows):
 * 0, or -1 when hours is not within (0, 24] or the schedule has no free length. */
int scene_config_set_hours(struct scene_config *cfg, double hours);

/* Rows a configuration produces. */
uint64_t scene_config_rows(const struct scene_config *cfg);

/*
 * Starts generating cfg with seed. Loads the shared recording if cfg->real_noise
 * (scene_shared_dir()). Returns 0, or -1 with a message in err (bad parameter,
 * unreadable or malformed recording). Release with scene_gen_free.
 */
int scene_gen_init(struct scene_gen *gen, const struct scene_config *cfg, uint64_t seed, char *err,
                   size_t errlen);

/* Like scene_gen_init but with an already loaded recording (not copied, not
 * freed; must outlive gen), so benchmarks load the file once. */
int scene_gen_init_with(struct scene_gen *gen, const struct scene_config *cfg, uint64_t seed,
                        const struct scene_real_noise *real, char *err, size_t errlen);

/*
 * Next row (info may be NULL). Returns 0 with a row, 1 when the scenario has
 * ended, or -1 with a message in err (a reading fell outside 0..65535 mm).
 */
int scene_gen_next(struct scene_gen *gen, struct scene_row *row, struct scene_row_info *info,
                   char *err, size_t errlen);

/* Message of the last scene_gen_next failure ("" if none). */
const char *scene_gen_error(const struct scene_gen *gen);

/* Releases the recording if gen loaded it. */
void scene_gen_free(struct scene_gen *gen);

/* Ground truth of the demo schedule at row index i (5000 rows, docs/reference/trace-format.md). */
void scene_demo_attitude(uint64_t i, double *alpha_deg, double *beta_deg);
#define SCENE_DEMO_ROWS 5000u

#endif /* SCENE_SCENARIO_H */
