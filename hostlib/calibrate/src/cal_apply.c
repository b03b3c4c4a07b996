/* A replay's head calibration: from the option or the trace, preloaded as a record
 * (calibrate/cal_apply.h). */
#include "calibrate/cal_apply.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "calibrate/head_cal.h"
#include "estimator/calibration.h"
#include "firmware/calibration_record.h"
#include "firmware/settings.h"
#include "hal/hal_err.h"

_Static_assert(TRACE_CAL_SENSORS == CALIBRATION_SENSORS &&
                   TRACE_CAL_OFFSET_MAX_UM == CALIBRATION_OFFSET_MAX_UM &&
                   TRACE_CAL_TEMP_COEFF_MAX_NM_PER_C == CALIBRATION_TEMP_COEFF_MAX_NM_PER_C &&
                   TRACE_CAL_TEMP_MIN_CDEG == CALIBRATION_TEMP_MIN_CDEG &&
                   TRACE_CAL_TEMP_MAX_CDEG == CALIBRATION_TEMP_MAX_CDEG &&
                   TRACE_CAL_GAIN_MAX_PPM == CALIBRATION_GAIN_MAX_PPM &&
                   TRACE_CAL_UNCAL_GAIN_SD_PPM == CALIBRATION_UNCAL_GAIN_SD_PPM,
               "the trace reader's calibration integers are the estimator's");

/* The binding keys of `hc` (head_id, distance_mode, timing_budget_ms). 0, or -1 (err). */
static int read_binding(const struct head_cal *hc, const char *path, struct cal_apply_binding *b,
                        char *err, size_t errlen) {
    memset(b, 0, sizeof *b);
    const char *v = head_cal_extra(hc, "head_id");
    char *end = NULL;
    if (v != NULL) {
        const unsigned long long id = strtoull(v, &end, 10);
        if (end == v || *end != '\0' || v[0] == '-' || id > UINT32_MAX) {
            snprintf(err, errlen, "%s: head_id '%s' is not an integer 0..4294967295", path, v);
            return -1;
        }
        b->has_head = true;
        b->head_id = (uint32_t)id;
    }
    if ((v = head_cal_extra(hc, "distance_mode")) != NULL) {
        b->has_mode = strcmp(v, "short") == 0 || strcmp(v, "long") == 0;
        if (!b->has_mode) {
            snprintf(err, errlen, "%s: distance_mode '%s' is not short or long", path, v);
            return -1;
        }
        b->mode = strcmp(v, "long") == 0 ? 2u : 1u; /* enum vl53_distance_mode */
    }
    if ((v = head_cal_extra(hc, "timing_budget_ms")) != NULL) {
        const unsigned long ms = strtoul(v, &end, 10);
        if (end == v || *end != '\0' || v[0] == '-' || ms == 0u || ms > UINT16_MAX) {
            snprintf(err, errlen, "%s: timing_budget_ms '%s' is not an integer 1..65535", path, v);
            return -1;
        }
        b->has_budget = true;
        b->budget_ms = (uint16_t)ms;
    }
    if ((v = head_cal_extra(hc, "arm_mm")) != NULL) {
        const double mm = strtod(v, &end);
        if (end == v || *end != '\0' || !(mm >= 1.0 && mm <= 1000.0)) {
            snprintf(err, errlen, "%s: arm_mm '%s' is not a number 1..1000", path, v);
            return -1;
        }
        b->has_arm = true;
        b->arm_um = (int32_t)lround(mm * 1000.0);
    }
    for (unsigned i = 0; i < 4u; ++i) {
        char key[16];
        snprintf(key, sizeof key, "part_id_%c", 'A' + i);
        if ((v = head_cal_extra(hc, key)) == NULL) {
            continue;
        }
        errno = 0;
        const unsigned long long id = strtoull(v, &end, 16);
        if (strncmp(v, "0x", 2) != 0 || strlen(v) < 3u || strlen(v) > 18u || *end != '\0' ||
            errno != 0 || id == 0u) {
            snprintf(err, errlen,
                     "%s: %s '%s' is not a part's NVM identity (0x and 1 to 16 hex digits, not 0)",
                     path, key, v);
            return -1;
        }
        b->part_id[i] = (uint64_t)id;
    }
    return 0;
}

int cal_apply_load(const char *path, struct trace_v1_cal *out, struct cal_apply_binding *made_in,
                   char *err, size_t errlen) {
    static struct head_cal hc; /* ~6 KB of keys */
    struct cal_apply_binding ignored;
    if (head_cal_load(path, &hc, err, errlen) != 0 ||
        read_binding(&hc, path, made_in != NULL ? made_in : &ignored, err, errlen) != 0) {
        return -1;
    }
    /* The file's text through the trace reader's exact conversion: a HEAD.cal and the same
     * keys inline give the same integers. */
    memset(out, 0, sizeof *out);
    for (unsigned k = 0; k < hc.count; ++k) {
        uint32_t col = 0;
        const char *what = NULL;
        const int rc = trace_v1_cal_value(out, hc.key[k], hc.value[k], hc.line[k], &col, &what);
        if (rc < 0 || (rc == 0 && strcmp(hc.key[k], "calibration") == 0)) {
            snprintf(err, errlen, "%s:%u: %s: %s", path, hc.line[k], hc.key[k],
                     rc < 0 ? what : "not a key of a head-calibration file");
            return -1;
        }
    }
    const char *what = NULL;
    uint32_t line = 0;
    if (trace_v1_cal_check(out, &what, &line) != 0 || !out->calibrated) {
        snprintf(err, errlen, "%s:%u: %s", path, line,
                 what != NULL ? what : "no offset_mm and offset_sd_mm");
        return -1;
    }
    return 0;
}

/* The path of `file` relative to the directory of `trace_path`. */
static void beside(const char *trace_path, const char *file, char *out, size_t cap) {
    const char *slash = strrchr(trace_path, '/');
    if (file[0] == '/' || slash == NULL) {
        snprintf(out, cap, "%s", file);
    } else {
        snprintf(out, cap, "%.*s/%s", (int)(slash - trace_path), trace_path, file);
    }
}

int cal_apply_resolve(const char *prog, const char *option, const struct trace_v1_meta *meta,
                      const char *trace_path, struct cal_apply *out) {
    memset(out, 0, sizeof *out);
    char path[256];
    const char *file = option;
    if (file == NULL && (meta->cal.keys & TRACE_CAL_KEY_FILE) != 0u) {
        for (unsigned k = 0; k < meta->count; ++k) {
            if (strcmp(meta->key[k], "calibration") == 0) {
                beside(trace_path, meta->value[k], path, sizeof path);
                file = path;
            }
        }
    }
    if (file != NULL) {
        char err[HEAD_CAL_ERR_MAX];
        if (cal_apply_load(file, &out->cal, &out->made_in, err, sizeof err) != 0) {
            fprintf(stderr, "%s: %s%s\n", prog, option != NULL ? "--calibration: " : "", err);
            return -1;
        }
        snprintf(out->source, sizeof out->source, "%s", file);
        return 0;
    }
    out->cal = meta->cal; /* inline keys, calibration=none, or nothing: uncalibrated */
    snprintf(out->source, sizeof out->source, "%s",
             out->cal.calibrated ? "the trace's keys" : "none (uncalibrated)");
    return 0;
}

void cal_apply_head(const struct trace_v1_cal *cal, struct calibration_head *out) {
    memset(out, 0, sizeof *out);
    out->calibrated = cal->calibrated;
    for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
        out->offset_um[i] = cal->offset_um[i];
        out->gain_ppm[i] = cal->gain_ppm[i];
        out->offset_sd_um[i] = cal->offset_sd_um[i];
        out->gain_sd_ppm[i] = cal->gain_sd_ppm[i];
        out->offset_gain_corr_q15[i] = cal->corr_q15[i];
        out->temp_coeff_nm_per_c[i] = cal->thermal ? cal->temp_coeff_nm_per_c[i] : 0;
        out->temp_coeff_sd_nm_per_c[i] = cal->thermal ? cal->temp_coeff_sd_nm_per_c[i] : 0u;
    }
    /* units as estimator/calibration.h states them: 0.01 °C, nm/°C (the trace reader's) */
    out->thermal = cal->calibrated && cal->thermal;
    out->cal_temp_cdeg = cal->thermal ? cal->cal_temp_cdeg : 0;
}

int cal_apply_preload(const struct trace_v1_cal *cal, const struct tof_app_config *cfg,
                      const struct cal_apply_binding *made_in, const uint8_t *pages_in,
                      struct sim_flash *flash, struct tof_record_store *store) {
    if (sim_flash_init(flash, 2u, CAL_APPLY_PAGE_SIZE) != HAL_OK) {
        fprintf(stderr, "internal: the simulated record storage\n");
        return -1;
    }
    for (unsigned p = 0; p < 2u && pages_in != NULL; ++p) {
        memcpy(flash->mem[p], &pages_in[p * CAL_APPLY_PAGE_SIZE], CAL_APPLY_PAGE_SIZE);
    }
    if (tof_record_init(store, sim_flash_hal(flash), 0u, 1u) != HAL_OK) {
        fprintf(stderr, "internal: the simulated record storage\n");
        return -1;
    }
    if (!cal->calibrated) {
        return 0; /* nothing written: the firmware boots with what the pages hold */
    }
    (void)tof_record_load(store); /* the record in use, whose other sections are kept */
    struct calibration_head head;
    cal_apply_head(cal, &head);
    struct tof_cal_binding bind = tof_cal_binding_of(cfg);
    if (made_in != NULL) {
        bind.head_id = made_in->has_head ? made_in->head_id : bind.head_id;
        bind.mode = made_in->has_mode ? made_in->mode : bind.mode;
        bind.budget_ms = made_in->has_budget ? made_in->budget_ms : bind.budget_ms;
    }
    /* As the flight unit stores it: version 2, bound to the parts the file names (none
     * named: bound to none, so it holds for the parts that run) */
    static const uint64_t unnamed[4] = {0u, 0u, 0u, 0u};
    uint8_t wire[TOF_CAL_WIRE_SIZE];
    uint8_t section[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    if (tof_cal_encode(&head, cal->has_gain, &bind, wire) != HAL_OK ||
        tof_cal_bind_parts(wire, made_in != NULL ? made_in->part_id : unnamed, section) != HAL_OK) {
        fprintf(stderr, "internal: the calibration does not make a record\n");
        return -1;
    }
    /* bound to the arm it was made at: the file's, else the configuration's */
    tof_cal_bind_arm(section,
                     made_in != NULL && made_in->has_arm ? made_in->arm_um : cfg->estimator.arm_um);
    const int at = store->current < 0
                       ? -1
                       : tof_section_find(store->payload, store->length, TOF_SECTION_CALIBRATION);
    if (at >= 0 && (size_t)store->length - (size_t)at >= sizeof section &&
        memcmp(&store->payload[at], section, sizeof section) == 0) {
        return 0; /* already there (pages kept from a run before): left as they are */
    }
    if (tof_section_save(store, section) != HAL_OK) {
        fprintf(stderr, "internal: the calibration does not make a record\n");
        return -1;
    }
    sim_flash_power_on(flash); /* the record is in place before the firmware boots */
    return tof_record_init(store, sim_flash_hal(flash), 0u, 1u) == HAL_OK ? 0 : -1;
}
