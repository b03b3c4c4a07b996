/*
 * Why an estimate is not `ok` (docs/reference/tools.md `why`): the reasons an estimate names
 * (enum attitude_reason) and the set of reasons it carries (attitude_why_t), one bit
 * each. Owned by the estimator's top level (estimator/attitude.h); the window's
 * integrity (estimator/integrity.h) sets the per-sensor and window bits without
 * depending on the facade.
 */
#ifndef ESTIMATOR_ATTITUDE_WHY_H
#define ESTIMATOR_ATTITUDE_WHY_H

#include <stdint.h>

enum attitude_reason {
    ATTITUDE_REASON_NONE = 0,
    ATTITUDE_REASON_FLAGGED_DATA,       /* degraded: readings flagged, missing or gated out */
    ATTITUDE_REASON_SENSOR_MISSING,     /* degraded: a sensor gave nothing usable: 3 sensors */
    ATTITUDE_REASON_KALMAN_RESTARTED,   /* degraded: the filter restarted inside the window */
    ATTITUDE_REASON_ALPHA_UNOBSERVABLE, /* invalid: α cannot be determined (β may be valid) */
    ATTITUDE_REASON_BETA_UNOBSERVABLE,  /* invalid: β cannot be determined (α may be valid) */
    ATTITUDE_REASON_UNOBSERVABLE,       /* invalid: neither angle */
    ATTITUDE_REASON_DISABLED,           /* invalid: estimator not selected in the config */
    ATTITUDE_REASON_NO_CONVERGENCE,     /* invalid: product consensus missed its proven bound */
    ATTITUDE_REASON_PAPER_TOO_FEW_ROWS, /* invalid: fewer than 2 rows with all four sensors */
    ATTITUDE_REASON_PAPER_NONPOSITIVE_VARIANCE,
    ATTITUDE_REASON_PAPER_ZERO_COVARIANCE,
    ATTITUDE_REASON_PAPER_ZERO_ROW_SUM,
    ATTITUDE_REASON_PAPER_NEGATIVE_ROW_SUM,
    ATTITUDE_REASON_PAPER_OVERFLOW,
    ATTITUDE_REASON_PAPER_DIVERGED,
    ATTITUDE_REASON_PAPER_NO_CONVERGENCE,
    ATTITUDE_REASON_PAPER_OUTSIDE_HULL,
    ATTITUDE_REASON_PAPER_INCONSISTENT, /* converged, but too far from the product estimate */
    ATTITUDE_REASON_COUNT,
};

/*
 * The why set, one bit each. Per sensor k (0..3 = A..D):
 *   no-target:X  a reading the part gives when it saw nothing (8190, 8191, 65535),
 *                whatever its status: never used
 *   range:X      a reading of 0 or beyond the mode's range (range_max_mm): never used
 *   flagged:X    a reading with a non-zero range status
 *   missing:X    no reading at all (the sensor did not deliver)
 *   rejected:X   a status-0 reading the estimator's outlier gate left out
 * Per window:
 *   parity       the sensors disagree with a flat plate: x_A + x_C − x_B − x_D beyond
 *                what their sd allows; the sd then covers that disagreement in any one
 *   motion       the plate moved inside the window (a step or ramp): the sd includes it
 *   drift        the learnt drift of the sensors' offsets exceeds drift_flag_um
 *   uncalibrated the head has no calibration (attitude_config.calibration.calibrated
 *                false): offset 0 and gain 1 assumed, the parts' spread in the sd, never
 *                ok
 *   recalibrate  the drift the parity shows exceeds the allowance since the start
 *                (offset stability plus the prior walk): the calibration no longer holds
 * and one bit per enum attitude_reason value r, ATTITUDE_WHY_REASON(r) (NONE has none;
 * the summaries flagged-data and sensor-missing appear only when no other bit says why).
 * An estimate is `ok` exactly when both angles are valid and its set is empty.
 */
typedef uint64_t attitude_why_t;
#define ATTITUDE_WHY_NO_TARGET(k) ((attitude_why_t)1u << (0u + (unsigned)(k)))
#define ATTITUDE_WHY_RANGE(k)     ((attitude_why_t)1u << (4u + (unsigned)(k)))
#define ATTITUDE_WHY_FLAGGED(k)   ((attitude_why_t)1u << (8u + (unsigned)(k)))
#define ATTITUDE_WHY_MISSING(k)   ((attitude_why_t)1u << (12u + (unsigned)(k)))
#define ATTITUDE_WHY_REJECTED(k)  ((attitude_why_t)1u << (16u + (unsigned)(k)))
#define ATTITUDE_WHY_PARITY       ((attitude_why_t)1u << 20u)
#define ATTITUDE_WHY_MOTION       ((attitude_why_t)1u << 21u)
#define ATTITUDE_WHY_DRIFT        ((attitude_why_t)1u << 22u)
#define ATTITUDE_WHY_UNCALIBRATED ((attitude_why_t)1u << 23u)
#define ATTITUDE_WHY_RECALIBRATE  ((attitude_why_t)1u << 24u)
#define ATTITUDE_WHY_REASON_SHIFT 32u
#define ATTITUDE_WHY_REASON(r)    ((attitude_why_t)1u << (ATTITUDE_WHY_REASON_SHIFT + (unsigned)(r)))

#endif /* ESTIMATOR_ATTITUDE_WHY_H */
