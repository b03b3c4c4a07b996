/* A simulated calibration fixture: a head with offsets and gains at known stations (fixture.h). */
#include "calibrate/fixture.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scene/geometry.h"
#include "scene/noise.h"
#include "scene/thermal.h"

const char *const fixture_names[] = {"fixture",
                                     "fixture-ar1",
                                     "fixture-drift",
                                     "fixture-one-distance",
                                     "fixture-realnoise",
                                     "fixture-thermal",
                                     "fixture-thermal-narrow",
                                     "fixture-thermal-blind",
                                     NULL};

/* RNG streams of one seed, one per purpose (as the scenarios do). */
enum {
    STREAM_HEAD = 20,
    STREAM_ORDER = 21,
    STREAM_NOISE0 = 22,
    STREAM_DITHER = 26,
    STREAM_STRETCH = 27,
    STREAM_COEFF = 28,
    STREAM_STATION_TEMP = 29,
    STREAM_TEMP_NOISE = 30
};

/* The fixture's distances (60–200 mm, the capture interface's working range) and attitudes
 * (±5°, ±10°, level): station s takes distance s mod 5 and attitude s mod 8, so the 20
 * stations mix them. */
static const double distances_mm[5] = {60.0, 95.0, 130.0, 165.0, 200.0};
static const double attitudes_deg[8][2] = {{0, 0},    {5, 0},   {-5, 5}, {10, -5},
                                           {-10, 10}, {0, -10}, {5, 10}, {-5, -5}};

static void set_stations(struct fixture_config *c, unsigned n) {
    c->n_stations = n;
    for (unsigned s = 0; s < c->n_stations; ++s) {
        c->distance_mm[s] = distances_mm[s % 5u];
        c->alpha_deg[s] = attitudes_deg[s % 8u][0];
        c->beta_deg[s] = attitudes_deg[s % 8u][1];
    }
}

/* A fixture in a temperature chamber (docs/how-to/calibrate-a-head.md, "Temperature"): the
 * stations in blocks, one per chamber temperature, each block holding every distance twice
 * (10 stations: 5 distances, attitudes s mod 8), visited in a random order within its block. */
static void thermal(struct fixture_config *c, unsigned n_temps, const double *temps, double ref) {
    set_stations(c, 10u * n_temps);
    c->n_temps = n_temps;
    for (unsigned b = 0; b < n_temps; ++b) {
        c->temp_c[b] = temps[b];
    }
    c->temp_ref_c = ref;
    c->temp_wander_c = 0.3; /* a chamber holds its setpoint to a few tenths of a degree */
    c->coeff_range_mm_per_c = SCENE_THERMAL_COEFF_RANGE_MM_PER_C;
    c->temp_column = true;
    c->temp_noise_c = SCENE_THERMAL_TEMP_NOISE_C;
    c->temp_quantum_c = SCENE_THERMAL_TEMP_QUANTUM_C;
}

int fixture_named(const char *name, struct fixture_config *c) {
    memset(c, 0, sizeof *c);
    snprintf(c->name, sizeof c->name, "%s", name != NULL ? name : "");
    c->arm_mm = 30.0;
    c->period_ms = 20u;
    set_stations(c, 20u);
    c->shuffle = true;
    /* 20 × 750 readings at 20 ms: 5 min at the stations, offsets stated to 0.049 mm
     * (1 sd) on average at σ = 2 mm (docs/how-to/calibrate-a-head.md, "How long"). */
    c->readings_per_station = 750u;
    c->move_rows = 25u;
    c->sigma_mm = 2.0;
    c->offset_range_mm = 20.0; /* VL53L1X datasheet: up to ±20 mm before offset calibration */
    c->gain_range = 0.03;
    c->quantise = true;
    if (name == NULL) {
        return -1;
    }
    if (strcmp(name, "fixture") == 0) {
        return 0;
    }
    if (strcmp(name, "fixture-ar1") == 0) {
        c->ar1_phi = 0.9; /* τ = (1 + φ)/(1 − φ) = 19 readings */
        return 0;
    }
    if (strcmp(name, "fixture-drift") == 0) {
        c->drift_mm = 0.5;
        return 0;
    }
    if (strcmp(name, "fixture-one-distance") == 0) {
        for (unsigned s = 0; s < c->n_stations; ++s) {
            c->distance_mm[s] = 100.0;
        }
        return 0;
    }
    if (strcmp(name, "fixture-realnoise") == 0) {
        c->real_noise = true;
        c->sigma_mm = 0.0;
        return 0;
    }
    /* 10, 25 and 40 °C: a 30 °C span, the spacecraft's orbital swing's most of it */
    static const double wide[3] = {10.0, 25.0, 40.0};
    if (strcmp(name, "fixture-thermal") == 0 || strcmp(name, "fixture-thermal-blind") == 0) {
        thermal(c, 3u, wide, 25.0);
        c->temp_column = strcmp(name, "fixture-thermal") == 0; /* blind: not recorded */
        return 0;
    }
    /* 22 and 28 °C: a room's day, too narrow a span to tell the coefficient */
    static const double narrow[2] = {22.0, 28.0};
    if (strcmp(name, "fixture-thermal-narrow") == 0) {
        thermal(c, 2u, narrow, 25.0);
        return 0;
    }
    return -1;
}

static int bad(char *err, size_t errlen, const char *name, const char *what) {
    snprintf(err, errlen, "scenario %s: %s", name, what);
    return -1;
}

static int load_real(struct fixture_gen *g, uint64_t seed, char *err, size_t errlen) {
    char path[1200];
    if (scene_real_noise_default_path(path, sizeof path) != 0) {
        return bad(err, errlen, g->cfg.name, "path of the shared recording too long");
    }
    if (scene_real_noise_load(path, &g->real, err, errlen) != 0) {
        return -1;
    }
    /* Each sensor a seeded stretch of its own quarter of the recording (as `realnoise`). */
    struct scene_rng rng;
    scene_rng_seed(&rng, seed, STREAM_STRETCH);
    const size_t q = g->real.quarter_len;
    const size_t len = (size_t)g->total_rows;
    for (unsigned k = 0; k < 4u; ++k) {
        const size_t offset = len < q ? scene_rng_below(&rng, (uint32_t)(q - len + 1u)) : 0u;
        if (scene_real_stretch_init(&g->real, k, offset, len, &g->stretch[k]) != 0) {
            return bad(err, errlen, g->cfg.name, "cannot take a stretch of the recording");
        }
    }
    return 0;
}

int fixture_gen_init(struct fixture_gen *g, const struct fixture_config *cfg, uint64_t seed,
                     char *err, size_t errlen) {
    memset(g, 0, sizeof *g);
    g->cfg = *cfg;
    const struct fixture_config *c = &g->cfg;
    if (c->n_stations == 0u || c->n_stations > FIXTURE_MAX_STATIONS ||
        c->readings_per_station == 0u || !(c->arm_mm > 0.0) || !(c->sigma_mm >= 0.0) ||
        !(c->ar1_phi >= 0.0 && c->ar1_phi < 1.0) || c->n_temps > FIXTURE_MAX_TEMPS ||
        c->n_temps > c->n_stations || !(c->coeff_range_mm_per_c >= 0.0) ||
        !(c->temp_wander_c >= 0.0) || !(c->temp_noise_c >= 0.0) ||
        (c->temp_column && !(c->temp_quantum_c > 0.0))) {
        return bad(err, errlen, c->name, "parameter out of range");
    }
    g->total_rows = (uint64_t)c->n_stations * c->readings_per_station +
                    (uint64_t)(c->n_stations - 1u) * c->move_rows;
    struct scene_rng head;
    scene_rng_seed(&head, seed, STREAM_HEAD);
    for (unsigned k = 0; k < 4u; ++k) {
        g->offset_mm[k] = scene_rng_range(&head, -c->offset_range_mm, c->offset_range_mm);
        g->gain[k] = 1.0 + scene_rng_range(&head, -c->gain_range, c->gain_range);
        g->drift_total_mm[k] = scene_rng_range(&head, -c->drift_mm, c->drift_mm);
        scene_rng_seed(&g->noise_rng[k], seed, STREAM_NOISE0 + k);
        g->ar_state[k] = c->sigma_mm * scene_rng_normal(&g->noise_rng[k]); /* stationary */
    }
    scene_rng_seed(&g->dither_rng, seed, STREAM_DITHER);
    for (unsigned s = 0; s < c->n_stations; ++s) {
        g->order[s] = s;
    }
    /* Temperature blocks (one when n_temps is 0): the fixture visits them in order, the
     * stations of each in a random order. */
    const unsigned blocks = c->n_temps > 0u ? c->n_temps : 1u;
    if (c->shuffle) {
        struct scene_rng rng;
        scene_rng_seed(&rng, seed, STREAM_ORDER);
        for (unsigned b = 0; b < blocks; ++b) {
            const unsigned lo = b * c->n_stations / blocks;
            const unsigned hi = (b + 1u) * c->n_stations / blocks;
            for (unsigned s = hi - 1u; s > lo; --s) { /* Fisher–Yates */
                const unsigned j = lo + scene_rng_below(&rng, s - lo + 1u);
                const unsigned t = g->order[s];
                g->order[s] = g->order[j];
                g->order[j] = t;
            }
        }
    }
    struct scene_rng coeff_rng, station_rng;
    scene_rng_seed(&coeff_rng, seed, STREAM_COEFF);
    scene_rng_seed(&station_rng, seed, STREAM_STATION_TEMP);
    scene_rng_seed(&g->temp_rng, seed, STREAM_TEMP_NOISE);
    for (unsigned k = 0; k < 4u && c->n_temps > 0u; ++k) {
        g->coeff_mm_per_c[k] =
            scene_rng_range(&coeff_rng, -c->coeff_range_mm_per_c, c->coeff_range_mm_per_c);
    }
    for (unsigned s = 0; s < c->n_stations && c->n_temps > 0u; ++s) {
        g->station_temp_c[s] = c->temp_c[s * c->n_temps / c->n_stations] +
                               c->temp_wander_c * scene_rng_normal(&station_rng);
    }
    if (c->real_noise && load_real(g, seed, err, errlen) != 0) {
        fixture_gen_free(g);
        return -1;
    }
    return 0;
}

void fixture_gen_free(struct fixture_gen *g) {
    scene_real_noise_free(&g->real);
}

/* Sensor k's noise for row i. */
static double noise(struct fixture_gen *g, unsigned k, uint64_t i) {
    const struct fixture_config *c = &g->cfg;
    double e = 0.0;
    if (c->real_noise) {
        /* Real readings are whole millimetres: a uniform dither keeps the re-rounding
         * unbiased (as the `realnoise` scenario does). */
        e = scene_real_stretch_noise(&g->stretch[k], (size_t)i) +
            scene_rng_uniform(&g->dither_rng) - 0.5;
    }
    const double z = scene_rng_normal(&g->noise_rng[k]);
    if (c->ar1_phi > 0.0) {
        g->ar_state[k] =
            c->ar1_phi * g->ar_state[k] + sqrt(1.0 - c->ar1_phi * c->ar1_phi) * c->sigma_mm * z;
        return e + g->ar_state[k];
    }
    return e + c->sigma_mm * z;
}

int fixture_gen_next(struct fixture_gen *g, struct scene_row *row, double raw_mm[4], char *err,
                     size_t errlen) {
    const struct fixture_config *c = &g->cfg;
    if (g->row >= g->total_rows) {
        return 1;
    }
    const uint64_t i = g->row;
    const uint64_t cycle = (uint64_t)c->readings_per_station + c->move_rows;
    const unsigned slot = (unsigned)(i / cycle);
    const uint64_t within = i % cycle;
    const unsigned s = g->order[slot];
    double x[4];
    scene_ideal_distances(c->arm_mm, c->distance_mm[s], c->alpha_deg[s], c->beta_deg[s], x);
    memset(row, 0, sizeof *row);
    row->t_ms = (uint32_t)(i * c->period_ms);
    if (within < c->readings_per_station) {
        row->has_alpha = row->has_beta = row->has_distance = true;
        row->alpha_deg = c->alpha_deg[s];
        row->beta_deg = c->beta_deg[s];
        row->distance_mm = c->distance_mm[s];
    } else { /* moving to the next station: the plate between the two, no truth */
        const unsigned n = g->order[slot + 1u];
        double to[4];
        scene_ideal_distances(c->arm_mm, c->distance_mm[n], c->alpha_deg[n], c->beta_deg[n], to);
        const double f = (double)(within - c->readings_per_station + 1u) / (c->move_rows + 1u);
        for (unsigned k = 0; k < 4u; ++k) {
            x[k] += (to[k] - x[k]) * f;
        }
    }
    /* The offset moves linearly over the run, centred so its run average is offset_mm, and
     * with the station's temperature (the moving rows: the station just left). */
    const double phase = g->total_rows > 1u ? (double)i / (double)(g->total_rows - 1u) - 0.5 : 0.0;
    const double dt = c->n_temps > 0u ? g->station_temp_c[s] - c->temp_ref_c : 0.0;
    if (c->temp_column) {
        const double m = g->station_temp_c[s] + c->temp_noise_c * scene_rng_normal(&g->temp_rng);
        row->has_temp = true;
        row->temp_c = round(round(m / c->temp_quantum_c) * c->temp_quantum_c * 100.0) / 100.0;
    }
    for (unsigned k = 0; k < 4u; ++k) {
        const double v = g->gain[k] * x[k] + g->offset_mm[k] + g->drift_total_mm[k] * phase +
                         g->coeff_mm_per_c[k] * dt + noise(g, k, i);
        if (raw_mm != NULL) {
            raw_mm[k] = v;
        }
        uint16_t mm = 0;
        if (scene_quantise_mm(v, &mm) != 0) {
            snprintf(err, errlen,
                     "scenario %s: row %llu sensor %c: reading %.1f mm outside "
                     "0..65535",
                     c->name, (unsigned long long)i, (char)('A' + k), v);
            return -1;
        }
        row->range_mm[k] = mm;
        row->present[k] = true;
    }
    g->row++;
    return 0;
}

static int write_header(FILE *f, const struct fixture_gen *g, uint64_t seed) {
    const struct fixture_config *c = &g->cfg;
    int n = fprintf(f, "# tof-trace v1\n# arm_mm=%g\n# period_ms=%u\n# scenario=%s\n# seed=%llu\n",
                    c->arm_mm, (unsigned)c->period_ms, c->name, (unsigned long long)seed);
    n |= fprintf(f, "# fixture=%u stations x %u readings%s, %u rows moving between them\n",
                 c->n_stations, (unsigned)c->readings_per_station,
                 c->shuffle ? " in a random order" : "", (unsigned)c->move_rows);
    if (c->real_noise) {
        n |= fprintf(f, "# noise=real VL53L0X recording, tomisuarez2/TimeOfFlightCalibration "
                        "(MIT)\n");
    } else {
        n |= fprintf(f, "# noise=gaussian sigma_mm=%g ar1_phi=%g\n", c->sigma_mm, c->ar1_phi);
    }
    /* The simulated head's truth (docs/how-to/calibrate-a-head.md): not calibration keys, so a
     * replay of this raw trace treats the head as uncalibrated, as it is. */
    n |= fprintf(f, "# sim_offset_mm=%.6f,%.6f,%.6f,%.6f\n", g->offset_mm[0], g->offset_mm[1],
                 g->offset_mm[2], g->offset_mm[3]);
    n |= fprintf(f, "# sim_gain=%.8f,%.8f,%.8f,%.8f\n", g->gain[0], g->gain[1], g->gain[2],
                 g->gain[3]);
    n |= fprintf(f, "# sim_drift_mm=%.6f,%.6f,%.6f,%.6f\n", g->drift_total_mm[0],
                 g->drift_total_mm[1], g->drift_total_mm[2], g->drift_total_mm[3]);
    if (c->n_temps > 0u) {
        n |= fprintf(f, "# sim_temp_ref_c=%.2f\n", c->temp_ref_c);
        n |= fprintf(f, "# sim_temp_coeff_mm_per_c=%.9f,%.9f,%.9f,%.9f\n", g->coeff_mm_per_c[0],
                     g->coeff_mm_per_c[1], g->coeff_mm_per_c[2], g->coeff_mm_per_c[3]);
        n |= fprintf(f, "# sim_chamber_c=");
        for (unsigned b = 0; b < c->n_temps; ++b) {
            n |= fprintf(f, "%s%g", b ? "," : "", c->temp_c[b]);
        }
        n |= fprintf(f, " (head: +- N(0, %g) per station; temp_c: %s)\n", c->temp_wander_c,
                     c->temp_column ? "measured, noise sd and quantum below" : "not recorded");
        if (c->temp_column) {
            n |= fprintf(f, "# sim_temp_noise_c=%g quantum %g\n", c->temp_noise_c,
                         c->temp_quantum_c);
        }
    }
    n |= fprintf(f,
                 "t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg,distance_mm%s\n",
                 c->temp_column ? ",temp_c" : "");
    return n < 0 ? -1 : 0;
}

static int write_row(FILE *f, const struct scene_row *r, bool temp_column) {
    int n = fprintf(f, "%lu,%u,%u,%u,%u,0,0,0,0", (unsigned long)r->t_ms, r->range_mm[0],
                    r->range_mm[1], r->range_mm[2], r->range_mm[3]);
    if (r->has_alpha) {
        n |= fprintf(f, ",%.6f,%.6f,%.3f", r->alpha_deg, r->beta_deg, r->distance_mm);
    } else {
        n |= fputs(",,,", f);
    }
    if (temp_column) {
        n |= fprintf(f, ",%.2f", r->temp_c);
    }
    n |= fputs("\n", f);
    return n < 0 ? -1 : 0;
}

int fixture_write(const char *name, uint64_t seed, const char *path, char *err, size_t errlen) {
    struct fixture_config cfg;
    if (fixture_named(name, &cfg) != 0) {
        snprintf(err, errlen, "unknown scenario '%s'", name);
        return -1;
    }
    struct fixture_gen g;
    if (fixture_gen_init(&g, &cfg, seed, err, errlen) != 0) {
        return -1;
    }
    const bool to_stdout = strcmp(path, "-") == 0;
    FILE *f = to_stdout ? stdout : fopen(path, "wb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: cannot open for writing: %s", path, strerror(errno));
        fixture_gen_free(&g);
        return -1;
    }
    int rc = write_header(f, &g, seed);
    struct scene_row row;
    int got = 0;
    while (rc == 0 && (got = fixture_gen_next(&g, &row, NULL, err, errlen)) == 0) {
        rc = write_row(f, &row, cfg.temp_column);
    }
    if (got < 0) {
        rc = -1;
    } else if (rc != 0) {
        snprintf(err, errlen, "%s: write error: %s", path, strerror(errno));
    }
    if ((to_stdout ? fflush(f) : fclose(f)) != 0 && rc == 0) {
        snprintf(err, errlen, "%s: write error: %s", path, strerror(errno));
        rc = -1;
    }
    if (rc != 0 && !to_stdout) {
        remove(path);
    }
    fixture_gen_free(&g);
    return rc;
}
