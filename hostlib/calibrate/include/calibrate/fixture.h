/*
 * A simulated calibration fixture (docs/how-to/calibrate-a-head.md): a head whose parts have their
 * own offsets and gains (raw = gain · x + offset + noise, docs/explanation/architecture.md) looks
 * at a flat plate that a fixture holds at known stations (α, β, x̄) and moves between them. Rows at
 * a station carry the truth; rows while moving carry none. What the head truly is stands in the
 * trace's keys (sim_offset_mm, sim_gain, sim_drift_mm; with temperatures sim_temp_ref_c and
 * sim_temp_coeff_mm_per_c, sim_offset_mm then holding at sim_temp_ref_c), so a test can compare.
 */
#ifndef CALIBRATE_FIXTURE_H
#define CALIBRATE_FIXTURE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "scene/real_noise.h"
#include "scene/rng.h"
#include "scene/row.h"

#define FIXTURE_MAX_STATIONS 64u
#define FIXTURE_MAX_TEMPS    8u

struct fixture_config {
    char name[32];
    double arm_mm;
    uint32_t period_ms;
    unsigned n_stations;
    double alpha_deg[FIXTURE_MAX_STATIONS], beta_deg[FIXTURE_MAX_STATIONS];
    double distance_mm[FIXTURE_MAX_STATIONS];
    bool shuffle;                  /* visit the stations in a seeded random order */
    uint32_t readings_per_station; /* rows at each station */
    uint32_t move_rows;            /* rows without truth between stations */
    double sigma_mm;               /* Gaussian noise per reading (before 1 mm rounding) */
    double ar1_phi;         /* 0 white; else AR(1): e_t = φ e_(t−1) + √(1−φ²) σ ε */
    bool real_noise;        /* the shared VL53L0X recording instead (sigma_mm 0) */
    double drift_mm;        /* each offset moves linearly over the run by a total in ±drift_mm */
    double offset_range_mm; /* offsets drawn uniform in ±this */
    double gain_range;      /* gains drawn uniform in 1 ± this */
    bool quantise;          /* whole millimetres, as the parts report (traces: always) */
    /* Temperatures (fixture-thermal): the stations in n_temps blocks, block b at the chamber's
     * temp_c[b] (the head's true temperature that plus a station's own N(0, temp_wander_c));
     * each offset moves by its coefficient (uniform in ±coeff_range_mm_per_c, scene/thermal.h)
     * times (T − temp_ref_c). temp_column: the rows carry the measured temperature (true plus
     * N(0, temp_noise_c) rounded to temp_quantum_c), as the unit records it. */
    unsigned n_temps; /* 0: one temperature, no thermal drift */
    double temp_c[FIXTURE_MAX_TEMPS];
    double temp_ref_c, temp_wander_c, coeff_range_mm_per_c;
    bool temp_column;
    double temp_noise_c, temp_quantum_c;
};

struct fixture_gen {
    struct fixture_config cfg;
    unsigned order[FIXTURE_MAX_STATIONS];
    double offset_mm[4]; /* the truth: the offset averaged over the run */
    double gain[4];
    double drift_total_mm[4]; /* offset at the end minus offset at the start */
    double coeff_mm_per_c[4]; /* the offsets' temperature coefficients (0 without n_temps) */
    double station_temp_c[FIXTURE_MAX_STATIONS]; /* each station's true head temperature */
    struct scene_rng temp_rng;
    uint64_t total_rows, row;
    struct scene_rng noise_rng[4];
    struct scene_rng dither_rng;
    double ar_state[4];
    struct scene_real_noise real;
    struct scene_real_stretch stretch[4];
};

/* Names of the fixture scenarios, NULL-terminated (docs/how-to/calibrate-a-head.md). */
extern const char *const fixture_names[];

/* The named fixture's parameters. Returns 0, or -1 if unknown. */
int fixture_named(const char *name, struct fixture_config *cfg);

/* Draws the head and the order from seed (and loads the recording for real noise).
 * Returns 0, or -1 with err. Release with fixture_gen_free. */
int fixture_gen_init(struct fixture_gen *g, const struct fixture_config *cfg, uint64_t seed,
                     char *err, size_t errlen);

/*
 * Next row; raw_mm (may be NULL) gets the readings before rounding. Returns 0, 1 at the
 * end, or -1 with err (a reading outside 0..65535 mm).
 */
int fixture_gen_next(struct fixture_gen *g, struct scene_row *row, double raw_mm[4], char *err,
                     size_t errlen);

void fixture_gen_free(struct fixture_gen *g);

/* Writes the named fixture with seed as a trace v1 at path ("-": stdout), with the truth
 * columns alpha_deg, beta_deg, distance_mm. Returns 0, or -1 with err. */
int fixture_write(const char *name, uint64_t seed, const char *path, char *err, size_t errlen);

#endif /* CALIBRATE_FIXTURE_H */
