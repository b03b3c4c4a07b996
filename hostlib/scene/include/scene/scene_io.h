/*
 * Writing scenarios as trace v1 files: what `scene_tool scenario` and later
 * `host_sim scenario NAME --seed S --trace-out TRACE.csv` (docs/reference/tools.md) do.
 */
#ifndef SCENE_SCENE_IO_H
#define SCENE_SCENE_IO_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "scene/scenario.h"

/*
 * Writes cfg generated with seed to f as a trace v1 (metadata: arm_mm,
 * period_ms, scenario, seed, mean_mm, window, noise; truth columns filled). A thermal
 * configuration also writes the temp_c column and its calibration keys (cal_temp_c,
 * temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c) with the simulation's truth (sim_*).
 * Returns 0, or -1 with a message in err.
 */
int scene_write_config(const struct scene_config *cfg, uint64_t seed, FILE *f, const char *path,
                       char *err, size_t errlen);

/*
 * Writes the named scenario (scene_scenario_names) with seed to the file at
 * path ("-" is stdout). Returns 0, or -1 with a message in err (unknown name,
 * unwritable file, missing shared recording, ...). A failed write removes the
 * partial file.
 */
int scene_write_scenario(const char *name, uint64_t seed, const char *path, char *err,
                         size_t errlen);

/* scene_write_scenario of a configuration (a named one with options changed). */
int scene_write_scenario_config(const struct scene_config *cfg, uint64_t seed, const char *path,
                                char *err, size_t errlen);

/* scene_config_named, with "unknown scenario 'X' (known: ...)" in err when it fails. */
int scene_config_named_listed(const char *name, struct scene_config *cfg, char *err, size_t errlen);

#endif /* SCENE_SCENE_IO_H */
