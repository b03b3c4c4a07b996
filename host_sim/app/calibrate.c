/* host_sim calibrate: a fixture trace's stations in, HEAD.cal out (calibrate.h). */
#include "calibrate.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "calibrate/calfit.h"
#include "calibrate/head_cal.h"
#include "estimator/calibration.h"
#include "firmware/config.h"
#include "hal/hal_err.h"
#include "replay_mode.h"
#include "scene/geometry.h"
#include "scene/trace.h"

const char calibrate_help[] =
    "usage: host_sim calibrate CAL_TRACE.csv --out HEAD.cal [--report CAL.json] "
    "[--accept-scatter]\n"
    "Fits each sensor's offset and gain (raw = gain * true + offset) from a fixture trace's\n"
    "stations: runs of rows with the same truth alpha_deg, beta_deg, distance_mm (rows\n"
    "without truth, the fixture moving, and readings whose status is not 0 are not used),\n"
    "with their sd from the stations' noise and scatter (docs/how-to/calibrate-a-head.md). With "
    "one\n"
    "fixture distance only the gains are not determined: offsets fitted at gain 1, and the\n"
    "gain left at the parts' stated spread with its correlation to the offset written, so\n"
    "the sd is exact at the fixture's distance and grows away from it. The HEAD.cal is\n"
    "bound to the configuration the trace was recorded in: its '# distance_mode=' and\n"
    "'# timing_budget_ms=', else the mode and budget host_sim replay would run it in, and\n"
    "to its arm_mm (written as arm_mm). The file ends with a checksum line of its content.\n"
    "Temperature: when every station's rows carry temp_c and the stations span 10 C or more,\n"
    "each offset's temperature coefficient (mm/C) is fitted with them and written with its sd\n"
    "and the calibration temperature (cal_temp_c, the stations' mean); otherwise the\n"
    "coefficient is unknown, said on stderr and in the report, and no thermal key written.\n"
    "Nothing is written for a fit no VL53 part can have (offset beyond 100 mm, gain outside\n"
    "0.9..1.1), whose station means fit another arm in every sensor (more than 5 sd from\n"
    "arm_mm), or whose scatter ratio exceeds 100 (wrong station truths). A sensor whose\n"
    "scatter ratio exceeds 3 is named with the likely cause (temperature, arm, motion); above\n"
    "10 with a cause between stations (temperature, arm, none found) nothing is written\n"
    "unless --accept-scatter.\n"
    "options:\n"
    "  --out HEAD.cal       the head-calibration file (docs/reference/calibration-file.md); "
    "required\n"
    "  --report CAL.json    the fit per sensor and the residuals per station\n"
    "  --accept-scatter     write a fit whose scatter ratio is 10..100 with a cause between\n"
    "                       stations (its sd widened by the scatter; the file says so)\n"
    "  --help, -h           this text\n"
    "exit status: 0 written, 1 bad input or a trace it cannot fit, 2 bad command line\n";

struct calibrate_args {
    const char *trace, *out, *report;
    bool accept_scatter;
};

static int usage(const char *what, const char *value) {
    if (value != NULL) {
        fprintf(stderr, "host_sim calibrate: %s: '%s'\n", what, value);
    } else {
        fprintf(stderr, "host_sim calibrate: %s\n", what);
    }
    fprintf(stderr, "run 'host_sim calibrate --help' for usage\n");
    return -1;
}

static int parse(int argc, char **argv, struct calibrate_args *a) {
    memset(a, 0, sizeof *a);
    for (int i = 1; i < argc; ++i) {
        const char *arg = argv[i];
        const char **dest = NULL;
        if (strcmp(arg, "--out") == 0) {
            dest = &a->out;
        } else if (strcmp(arg, "--report") == 0) {
            dest = &a->report;
        } else if (strcmp(arg, "--accept-scatter") == 0) {
            a->accept_scatter = true;
            continue;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            return usage("unknown option", arg);
        } else if (a->trace == NULL) {
            a->trace = arg;
            continue;
        } else {
            return usage("more than one trace given", arg);
        }
        if (i + 1 >= argc) {
            return usage("option needs a value", arg);
        }
        *dest = argv[++i];
    }
    if (a->trace == NULL) {
        return usage("missing CAL_TRACE.csv", NULL);
    }
    if (a->out == NULL) {
        return usage("missing --out HEAD.cal", NULL);
    }
    return 0;
}

/* The configuration the fixture's readings were taken in, which the HEAD.cal is bound to
 * (docs/how-to/calibrate-a-head.md, "What binds a record"): without it a calibration made in one
 * mode would be applied in another. */
struct cal_binding {
    enum vl53_distance_mode mode;
    unsigned budget_ms;
    char source[320]; /* why, for stderr (the mode's own text is up to 200) */
};

/* The trace's mode (stated, else as host_sim replay infers it) and budget (stated as
 * '# timing_budget_ms=', else the firmware's for the trace's period in that mode). 0, or -1
 * with the message in err. */
static int binding_of(struct trace_reader *r, const char *path, struct cal_binding *b, char *err,
                      size_t errlen) {
    struct replay_mode m;
    const uint32_t period_ms = trace_reader_timing(r)->period_ms;
    if (replay_mode_choose(&m, r, path, 0u, period_ms) != 0) {
        snprintf(err, errlen, "%s: its distance_mode cannot be used (above)", path);
        return -1;
    }
    b->mode = m.mode;
    const char *v = trace_reader_meta(r, "timing_budget_ms");
    if (v != NULL) {
        char *end = NULL;
        errno = 0;
        const unsigned long ms = strtoul(v, &end, 10);
        if (errno != 0 || end == v || *end != '\0' || ms == 0u || ms > 65535u) {
            snprintf(err, errlen, "%s:%lu: timing_budget_ms: '%s' is not an integer 1..65535", path,
                     trace_reader_meta_line(r, "timing_budget_ms"), v);
            return -1;
        }
        b->budget_ms = (unsigned)ms;
        snprintf(b->source, sizeof b->source, "mode from %s, budget from the trace (line %lu)",
                 m.source, trace_reader_meta_line(r, "timing_budget_ms"));
        return 0;
    }
    struct tof_app_config cfg;
    if (tof_app_config_for_replay(&cfg, (int32_t)lround(r->meta.arm_mm * 1000.0), period_ms, 100u,
                                  false, m.mode) != HAL_OK) {
        snprintf(err, errlen,
                 "%s: no firmware timing of %s mode fits period_ms %u: state the parts' budget "
                 "as '# timing_budget_ms='",
                 path, vl53_distance_mode_name(m.mode), (unsigned)period_ms);
        return -1;
    }
    b->budget_ms = cfg.timing.budget_ms;
    snprintf(b->source, sizeof b->source,
             "mode from %s, budget the firmware's for period_ms %u (no '# timing_budget_ms=')",
             m.source, (unsigned)period_ms);
    return 0;
}

/* Every row of the trace into d. 0, or -1 with "file:line:col: what" in err. */
static int read_trace(const char *path, struct calfit_data *d, struct cal_binding *b, char *err,
                      size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    struct trace_reader *r = malloc(sizeof *r);
    int rc = r != NULL ? trace_reader_open(r, f, path) : -1;
    if (r == NULL) {
        snprintf(err, errlen, "%s: out of memory", path);
    } else if (rc != 0) {
        snprintf(err, errlen, "%s", trace_reader_error(r));
    } else if (binding_of(r, path, b, err, errlen) != 0) {
        rc = -1;
    } else {
        /* Whole millimetres, as VL53 parts report and trace v1 stores them. */
        calfit_init(d, r->meta.arm_mm, 1.0);
        for (;;) {
            struct scene_row row;
            const int got = trace_reader_next(r, &row);
            if (got == 1) {
                break;
            }
            if (got < 0) {
                snprintf(err, errlen, "%s", trace_reader_error(r));
                rc = -1;
                break;
            }
            if (calfit_add_row(d, &row, (uint32_t)r->last_row_line) != 0) {
                snprintf(err, errlen, "%s: out of memory", path);
                rc = -1;
                break;
            }
        }
    }
    free(r);
    fclose(f);
    return rc;
}

/* "key=v1,v2,v3,v4", each value with `decimals` decimals. */
static void four(char *buf, size_t len, const char *key, int decimals, const double v[4]) {
    int n = snprintf(buf, len, "%s=", key);
    for (unsigned k = 0; k < 4u && n > 0 && (size_t)n < len; ++k) {
        n += snprintf(buf + n, len - (size_t)n, "%.*f", decimals, v[k]);
        if (k < 3u && (size_t)n < len) {
            n += snprintf(buf + n, len - (size_t)n, ",");
        }
    }
}

/* The parts' gain spread (estimator/calibration.h), as a gain sd. */
#define UNCAL_GAIN_SD ((double)CALIBRATION_UNCAL_GAIN_SD_PPM / 1e6)

static int write_cal(const char *path, const char *trace, const struct calfit_data *d,
                     const struct calfit_result *res, const struct cal_binding *b,
                     const char *accepted) {
    /* Gains written in both cases: fitted, or (one distance) the prior gain 1 ± the parts'
     * spread σg with what that prior does to the offset fitted at the fixture's distance xc:
     * raw = g·x + o read at xc with g taken as 1 gives ô = o + (g − 1)·xc, so
     * sd(ô)² = σo² + xc²σg² and corr(ô, ĝ) = −xc·σg / sd(ô); the estimator's
     * var = sd(ô)² + x²σg² + 2xρ·sd(ô)σg is then σo² + (x − xc)²σg²: exact at the fixture,
     * growing away from it (integrity_noise.c, calibration_var). */
    struct head_cal cal = {.has_gain = true};
    double noise[4], tau[4], ratio[4], rms[4], corr[4], readings[4];
    const double xc = d->distance_min_mm;
    for (unsigned k = 0; k < 4u; ++k) {
        const struct calfit_sensor *s = &res->sensor[k];
        cal.offset_mm[k] = s->offset_mm;
        cal.offset_sd_mm[k] = s->offset_sd_mm;
        cal.gain[k] = s->gain;
        cal.gain_sd[k] = s->gain_sd;
        corr[k] = s->corr;
        if (!res->gains) {
            cal.gain[k] = 1.0;
            cal.gain_sd[k] = UNCAL_GAIN_SD;
            cal.offset_sd_mm[k] = hypot(s->offset_sd_mm, xc * UNCAL_GAIN_SD);
            corr[k] = -xc * UNCAL_GAIN_SD / cal.offset_sd_mm[k];
        }
        noise[k] = s->noise_sd_mm;
        tau[k] = s->tau;
        ratio[k] = s->chi2_red;
        rms[k] = s->residual_rms_mm;
        readings[k] = (double)s->readings;
        /* the offset holds at cal_temp_c (calfit.h), the coefficient in the keys' units */
        cal.temp_coeff_mm_per_c[k] = s->temp_coeff_mm_per_c;
        cal.temp_coeff_sd_mm_per_c[k] = s->temp_coeff_sd_mm_per_c;
    }
    cal.thermal = res->thermal;
    cal.cal_temp_c = res->cal_temp_c;
    char kv[18][HEAD_CAL_VALUE_MAX + HEAD_CAL_KEY_MAX];
    const char *extra[19];
    unsigned n = 0;
    snprintf(kv[n++], sizeof kv[0], "fit=%s",
             res->gains ? "offsets+gains" : "offsets (gains: the parts' prior)");
    snprintf(kv[n++], sizeof kv[0], "distance_mode=%s", vl53_distance_mode_name(b->mode));
    snprintf(kv[n++], sizeof kv[0], "timing_budget_ms=%u", b->budget_ms);
    snprintf(kv[n++], sizeof kv[0], "arm_mm=%.6g", d->arm_mm);
    snprintf(kv[n++], sizeof kv[0], "stations=%zu", d->n_stations);
    four(kv[n++], sizeof kv[0], "readings", 0, readings);
    snprintf(kv[n++], sizeof kv[0], "distance_range_mm=%.3f,%.3f", d->distance_min_mm,
             d->distance_max_mm);
    if (!res->gains) {
        snprintf(kv[n++], sizeof kv[0], "cal_distance_mm=%.3f", d->distance_min_mm);
    }
    four(kv[n++], sizeof kv[0], "offset_gain_corr", 6, corr);
    four(kv[n++], sizeof kv[0], "noise_sd_mm", 4, noise);
    four(kv[n++], sizeof kv[0], "noise_tau", 2, tau);
    four(kv[n++], sizeof kv[0], "scatter_ratio", 3, ratio);
    four(kv[n++], sizeof kv[0], "residual_rms_mm", 4, rms);
    if (d->rows_with_temp > 0u && res->stations_no_temp < d->n_stations) {
        snprintf(kv[n++], sizeof kv[0], "temp_range_c=%.2f,%.2f", res->temp_min_c, res->temp_max_c);
    }
    if (res->thermal) {
        double corr_kc[4];
        for (unsigned k = 0; k < 4u; ++k) {
            corr_kc[k] = res->sensor[k].corr_offset_coeff;
        }
        four(kv[n++], sizeof kv[0], "offset_coeff_corr", 6, corr_kc);
    }
    if (accepted[0] != '\0') {
        snprintf(kv[n++], sizeof kv[0], "%.*s", (int)sizeof kv[0] - 1, accepted);
    }
    const char *base = strrchr(trace, '/');
    base = base != NULL ? base + 1 : trace;
    snprintf(kv[n++], sizeof kv[0], "source=%.100s", base);
    for (unsigned i = 0; i < n; ++i) {
        extra[i] = kv[i];
    }
    extra[n] = NULL;
    FILE *f = fopen(path, "wb");
    if (f == NULL) {
        fprintf(stderr, "host_sim calibrate: %s: cannot open for writing: %s\n", path,
                strerror(errno));
        return -1;
    }
    int rc = head_cal_write(f, &cal, extra);
    if (fclose(f) != 0 || rc != 0) {
        fprintf(stderr, "host_sim calibrate: %s: write error\n", path);
        remove(path);
        return -1;
    }
    return 0;
}

/* A fit no VL53 part can have (estimator/calibration.h's bounds: what replay and the flight
 * unit refuse) is an error here, naming the sensor and the value, not a file that replay
 * then refuses. 0, or -1 after the message. */
static int check_range(const char *trace, const struct calfit_result *res) {
    int rc = 0;
    for (unsigned k = 0; k < 4u; ++k) {
        const struct calfit_sensor *s = &res->sensor[k];
        const double gmax = (double)CALIBRATION_GAIN_MAX_PPM / 1e6;
        const double omax = (double)CALIBRATION_OFFSET_MAX_UM / 1e3;
        if (res->gains && !(fabs(s->gain - 1.0) <= gmax)) {
            fprintf(stderr,
                    "host_sim calibrate: %s: sensor %c: fitted gain %.6f is outside %.2f..%.2f, no "
                    "VL53 part's (a wrong station truth, a swapped sensor, or a part to "
                    "replace): nothing written\n",
                    trace, 'A' + k, s->gain, 1.0 - gmax, 1.0 + gmax);
            rc = -1;
        }
        if (!(fabs(s->offset_mm) <= omax)) {
            fprintf(stderr,
                    "host_sim calibrate: %s: sensor %c: fitted offset %.3f mm is beyond ±%.0f mm, "
                    "no VL53 part's: nothing written\n",
                    trace, 'A' + k, s->offset_mm, omax);
            rc = -1;
        }
    }
    return rc;
}

static void summary(const char *trace, const struct calfit_data *d, const struct calfit_result *res,
                    const struct cal_binding *b) {
    fprintf(stderr,
            "host_sim calibrate: %s: %zu stations from %llu rows; not used: %llu rows without "
            "truth (moving), %llu with partial truth, readings not valid A %llu B %llu C %llu "
            "D %llu (in %llu rows)\n",
            trace, d->n_stations, (unsigned long long)d->rows, (unsigned long long)d->rows_no_truth,
            (unsigned long long)d->rows_partial_truth, (unsigned long long)d->invalid[0],
            (unsigned long long)d->invalid[1], (unsigned long long)d->invalid[2],
            (unsigned long long)d->invalid[3], (unsigned long long)d->rows_with_invalid);
    if (!res->gains) {
        fprintf(stderr,
                "host_sim calibrate: every station at one distance (%.3f mm): gains not "
                "determined; offsets fitted at gain 1, the gain written as 1 +- %.6f (the parts' "
                "spread) with its correlation to the offset: the sd is the fit's at %.3f mm and "
                "grows by %.6f mm per mm away from it\n",
                d->distance_min_mm, UNCAL_GAIN_SD, d->distance_min_mm, UNCAL_GAIN_SD);
    }
    fprintf(stderr, "host_sim calibrate: bound to %s mode, timing budget %u ms (%s)\n",
            vl53_distance_mode_name(b->mode), b->budget_ms, b->source);
    char why[CALIBRATE_THERMAL_WHY_MAX];
    calibrate_thermal_why(d, res, why, sizeof why);
    if (res->thermal) {
        fprintf(stderr,
                "host_sim calibrate: temperature: stations at %.2f..%.2f C: each offset's "
                "temperature coefficient fitted; the offsets hold at cal_temp_c %.2f C\n",
                res->temp_min_c, res->temp_max_c, res->cal_temp_c);
    } else {
        fprintf(stderr,
                "host_sim calibrate: temperature: the offsets' temperature coefficients are "
                "unknown: %s; no thermal keys written: the offsets hold at the stations' "
                "temperatures only\n",
                why);
    }
    for (unsigned k = 0; k < 4u; ++k) {
        const struct calfit_sensor *s = &res->sensor[k];
        char gain[64];
        if (res->gains) {
            snprintf(gain, sizeof gain, "gain %.6f +- %.6f", s->gain, s->gain_sd);
        } else {
            snprintf(gain, sizeof gain, "gain not fitted (1 +- %.6f)", UNCAL_GAIN_SD);
        }
        char coeff[80] = "";
        if (res->thermal) {
            snprintf(coeff, sizeof coeff, ", temp coeff %.5f +- %.5f mm/C", s->temp_coeff_mm_per_c,
                     s->temp_coeff_sd_mm_per_c);
        }
        fprintf(stderr,
                "  %c: offset %.4f +- %.4f mm, %s%s, noise %.3f mm (tau %.1f%s), "
                "scatter ratio %.2f over %u dof\n",
                'A' + k, s->offset_mm, s->offset_sd_mm, gain, coeff, s->noise_sd_mm, s->tau,
                s->tau_settled ? "" : ", not settled", s->chi2_red, s->dof);
    }
}

int calibrate_main(int argc, char **argv) {
    struct calibrate_args a;
    if (parse(argc, argv, &a) != 0) {
        return 2;
    }
    struct calfit_data d;
    memset(&d, 0, sizeof d);
    struct cal_binding bind;
    memset(&bind, 0, sizeof bind);
    char err[1024];
    if (read_trace(a.trace, &d, &bind, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim calibrate: %s\n", err);
        calfit_free(&d);
        return 1;
    }
    struct calfit_result res;
    int rc = 0;
    if (calfit_run(&d, &res, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim calibrate: %s: %s\n", a.trace, err);
        rc = 1;
    }
    if (rc == 0) {
        summary(a.trace, &d, &res, &bind);
        char accepted[HEAD_CAL_VALUE_MAX];
        rc = check_range(a.trace, &res) == 0 &&
                     calibrate_check_scatter(a.trace, &d, &res, a.accept_scatter, accepted,
                                             sizeof accepted) == 0 &&
                     write_cal(a.out, a.trace, &d, &res, &bind, accepted) == 0
                 ? 0
                 : 1;
    }
    if (rc == 0 && a.report != NULL) {
        FILE *f = fopen(a.report, "wb");
        int wrc = f != NULL ? calibrate_write_report(f, a.trace, &d, &res) : -1;
        if (f != NULL && fclose(f) != 0) {
            wrc = -1;
        }
        if (wrc != 0) {
            fprintf(stderr, "host_sim calibrate: %s: cannot write the report\n", a.report);
            rc = 1;
        }
    }
    calfit_free(&d);
    return rc;
}
