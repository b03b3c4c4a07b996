/* Names and text of the facade: estimators, statuses, reasons, why sets and errors. */
#include <string.h>

#include "estimator/attitude.h"

const char *attitude_error_message(int err) {
    switch (err) {
    case ATTITUDE_ERR_NONE:
        return "";
    case ATTITUDE_ERR_ARM:
        return "arm_um outside [1000, 1000000] um";
    case ATTITUDE_ERR_WINDOW:
        return "window outside [2, ATTITUDE_WINDOW_MAX] rows";
    case ATTITUDE_ERR_MODE:
        return "mode is neither tumbling nor sliding";
    case ATTITUDE_ERR_ESTIMATORS:
        return "estimators selects none, or one unknown or not built into this image";
    case ATTITUDE_ERR_TOLERANCE:
        return "consensus_tolerance_udeg outside [1, 10000000]";
    case ATTITUDE_ERR_PAPER_ITERATIONS:
        return "paper_max_iterations is 0";
    case ATTITUDE_ERR_KALMAN_PROCESS_NOISE:
        return "kalman_process_noise_um2 too large";
    case ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE:
        return "kalman_initial_noise_um2 below 83334 (1/12 mm², the 1 mm rounding)";
    case ATTITUDE_ERR_KALMAN_WARMUP:
        return "kalman_warmup_rows outside [1, 8]";
    case ATTITUDE_ERR_KALMAN_NOISE_SHIFT:
        return "kalman_noise_shift above 8";
    case ATTITUDE_ERR_NULL:
        return "NULL state or config";
    case ATTITUDE_ERR_INTEGRITY:
        return "an integrity field out of range (range_max_mm 1..8189, parity/motion sigmas "
               "1..16 x 256, drift_shift 1..8, period_us 1000..10000000, max_rate_mdeg_s "
               "0..360000)";
    case ATTITUDE_ERR_BUFFER:
        return "buffer too small";
    case ATTITUDE_ERR_CALIBRATION:
        return "a calibration value out of range (|offset| and offset sd <= 100 mm, |gain - 1| "
               "and gain sd <= 10 %)";
    default:
        return "unknown attitude error";
    }
}

const char *attitude_estimator_name(enum attitude_estimator e) {
    switch (e) {
    case ATTITUDE_EST_CONSENSUS:
        return "consensus";
    case ATTITUDE_EST_PAPER:
        return "consensus-paper";
    case ATTITUDE_EST_KALMAN:
        return "kalman";
    case ATTITUDE_EST_MEAN:
        return "mean";
    default:
        return "unknown";
    }
}

const char *attitude_status_name(enum attitude_status s) {
    switch (s) {
    case ATTITUDE_OK:
        return "ok";
    case ATTITUDE_DEGRADED:
        return "degraded";
    case ATTITUDE_INVALID:
        return "invalid";
    default:
        return "unknown";
    }
}

const char *attitude_reason_name(enum attitude_reason r) {
    static const char *const names[ATTITUDE_REASON_COUNT] = {
        "none",
        "flagged-data",
        "sensor-missing",
        "kalman-restarted",
        "alpha-unobservable",
        "beta-unobservable",
        "unobservable",
        "disabled",
        "no-convergence",
        "paper-too-few-rows",
        "paper-nonpositive-variance",
        "paper-zero-covariance",
        "paper-zero-row-sum",
        "paper-negative-row-sum",
        "paper-overflow",
        "paper-diverged",
        "paper-no-convergence",
        "paper-outside-hull",
        "paper-inconsistent",
    };
    if ((unsigned)r >= (unsigned)ATTITUDE_REASON_COUNT) {
        return "unknown";
    }
    return names[r];
}

/* Appends "+name" (no '+' first) with an optional ":X" sensor letter; false when full. */
static bool why_append(char *buf, size_t cap, size_t *len, const char *name, char sensor) {
    size_t need = (*len != 0u ? 1u : 0u) + strlen(name) + (sensor != '\0' ? 2u : 0u);
    if (*len + need + 1u > cap) {
        return false;
    }
    if (*len != 0u) {
        buf[*len] = '+';
        (*len)++;
    }
    for (const char *c = name; *c != '\0'; ++c) {
        buf[*len] = *c;
        (*len)++;
    }
    if (sensor != '\0') {
        buf[*len] = ':';
        (*len)++;
        buf[*len] = sensor;
        (*len)++;
    }
    buf[*len] = '\0';
    return true;
}

int attitude_why_format(attitude_why_t why, char *buf, size_t cap) {
    static const char *const per_sensor[5] = {"no-target", "range", "flagged", "missing",
                                              "rejected"};
    static const char *const window[3] = {"parity", "motion", "drift"};
    if (buf == NULL || cap == 0u) {
        return buf == NULL ? ATTITUDE_ERR_NULL : ATTITUDE_ERR_BUFFER;
    }
    size_t len = 0;
    buf[0] = '\0';
    bool fits = true;
    for (unsigned g = 0; g < 5u && fits; ++g) {
        for (unsigned k = 0; k < ATTITUDE_SENSORS && fits; ++k) {
            if ((why & ((attitude_why_t)1u << (4u * g + k))) != 0u) {
                fits = why_append(buf, cap, &len, per_sensor[g], (char)('A' + k));
            }
        }
    }
    for (unsigned b = 0; b < 3u && fits; ++b) {
        if ((why & (ATTITUDE_WHY_PARITY << b)) != 0u) {
            fits = why_append(buf, cap, &len, window[b], '\0');
        }
    }
    if ((why & ATTITUDE_WHY_UNCALIBRATED) != 0u && fits) {
        fits = why_append(buf, cap, &len, "uncalibrated", '\0');
    }
    if (fits && (why & ATTITUDE_WHY_RECALIBRATE) != 0u) {
        fits = why_append(buf, cap, &len, "recalibrate", '\0');
    }
    for (unsigned r = 1; r < (unsigned)ATTITUDE_REASON_COUNT && fits; ++r) {
        if ((why & ATTITUDE_WHY_REASON(r)) != 0u) {
            fits = why_append(buf, cap, &len, attitude_reason_name((enum attitude_reason)r), '\0');
        }
    }
    if (!fits) {
        buf[0] = '\0';
        return ATTITUDE_ERR_BUFFER;
    }
    return (int)len;
}
