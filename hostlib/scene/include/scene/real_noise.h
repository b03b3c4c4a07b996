/*
 * Real VL53L0X noise from ../shared/traces (one hour of a static sensor, 20 ms
 * budget; MIT, Suárez et al., see that folder's SOURCE.md). The file is split
 * into four disjoint quarters, one per sensor (A..D); a scenario uses a
 * contiguous stretch of each quarter, centred on that stretch's own mean, as
 * additive noise on the ideal distances.
 */
#ifndef SCENE_REAL_NOISE_H
#define SCENE_REAL_NOISE_H

#include <stddef.h>
#include <stdint.h>

#include "scene/row.h"

/* The recording's path below the shared directory. */
#define SCENE_REAL_NOISE_FILE                                                                      \
    "traces/external/tomisuarez2_TimeOfFlightCalibration/static_tof_dist_data_1_h.csv"

/* Upper bound on readings accepted from the file (it holds 200,244). */
#define SCENE_REAL_NOISE_MAX 4000000u

struct scene_real_noise {
    double *readings;   /* all readings in file order (heap, owned) */
    size_t count;       /* number of readings */
    size_t quarter_len; /* readings per sensor quarter: count / 4 */
};

/*
 * The shared directory: $TOF_SHARED_DIR if set, else <repo>/../shared (the repo
 * path is compiled in). Writes it to buf; returns 0, or -1 if it does not fit.
 */
int scene_shared_dir(char *buf, size_t buflen);

/* Full path of the recording below scene_shared_dir(). Returns 0 or -1. */
int scene_real_noise_default_path(char *buf, size_t buflen);

/*
 * Loads the recording (format in its SOURCE.md: "Fs,<rate>", "Logging time,<s>",
 * "d", then one finite reading per line). On any bad line returns -1 with
 * "file:line: message" in err; nothing is skipped. Returns 0 on success.
 */
int scene_real_noise_load(const char *path, struct scene_real_noise *rn, char *err, size_t errlen);

/* Frees what scene_real_noise_load allocated; safe on a zeroed struct. */
void scene_real_noise_free(struct scene_real_noise *rn);

/* One sensor's stretch: `len` readings of quarter `sensor` starting at `offset`
 * (wrapping inside the quarter), with their mean and standard deviation. */
struct scene_real_stretch {
    const double *quarter; /* first reading of the sensor's quarter */
    size_t quarter_len;
    size_t offset;  /* first reading used, inside the quarter */
    double mean_mm; /* mean of the `len` readings used */
    double sd_mm;   /* their (population) standard deviation */
};

/* Prepares sensor's stretch of len readings from offset. Returns 0, or -1 if the
 * recording is empty or offset is outside the quarter. */
int scene_real_stretch_init(const struct scene_real_noise *rn, unsigned sensor, size_t offset,
                            size_t len, struct scene_real_stretch *st);

/*
 * Standard deviation of the slow component of the stretch's noise as seen by a
 * window of `window` readings: sqrt(max(0, var(means of consecutive windows) −
 * sd²/window)) over the first len readings. White noise gives ≈ 0; the shared
 * recording gives ≈ 0.55 mm at window 100 (docs/reference/trace-format.md, "Real noise").
 */
double scene_real_stretch_offset_sd(const struct scene_real_stretch *st, size_t len, size_t window);

/* Centred noise of reading i of the stretch (wrapping): reading − mean. */
double scene_real_stretch_noise(const struct scene_real_stretch *st, size_t i);

#endif /* SCENE_REAL_NOISE_H */
