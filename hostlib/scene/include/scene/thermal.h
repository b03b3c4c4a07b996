/*
 * The simulated head's thermal world (docs/reference/trace-format.md, "orbit-thermal"): the
 * head's temperature cycling once per orbit, each part's offset moving with it by its own
 * coefficient, a random walk of each offset on top, and the temperature as the unit measures
 * it (sensor noise and quantisation).
 *
 * No public VL53L1X figure for the offset's temperature coefficient exists: ST's datasheet
 * (DocID031281 §3.2.1) names "a temperature drift" of the ranging without a number, and the
 * nearest published figure is another part's (VL53L0X, ±30 mm over −20…70 °C, second-hand;
 * ../shared/calibration-notes.md item 6). The coefficients are therefore drawn from a range
 * that is an option, and nothing downstream depends on its value: the default
 * (SCENE_THERMAL_COEFF_RANGE_MM_PER_C) moves an offset by up to 1.5 mm over a 40 °C cycle, the
 * drift the measurements were made at; 0 gives a head without thermal drift, and the
 * option reaches 1 mm/°C (40 mm over the cycle), far beyond the VL53L0X figure's 0.33 mm/°C.
 */
#ifndef SCENE_THERMAL_H
#define SCENE_THERMAL_H

#include <stdbool.h>
#include <stdint.h>

#include "scene/rng.h"

#define SCENE_THERMAL_SENSORS 4u

/* A low Earth orbit's period, about 90 minutes (ISS: 92.7 min; 90 min at 280 km). */
#define SCENE_THERMAL_PERIOD_S 5400.0
/* The head's temperature, mean and half the peak-to-peak swing: a 40 °C cycle about 20 °C. */
#define SCENE_THERMAL_MEAN_C      20.0
#define SCENE_THERMAL_AMPLITUDE_C 20.0
/* Coefficients uniform in ±this: 1.5 mm over a 40 °C swing at the range's ends. */
#define SCENE_THERMAL_COEFF_RANGE_MM_PER_C 0.0375
#define SCENE_THERMAL_COEFF_MAX_MM_PER_C   1.0 /* the estimator's bound (1 000 000 nm/°C) */
/* The coefficient's sd the trace states with it (the stated value is drawn about the true one
 * with this sd): what the fixture-thermal scenario's fit gives, docs/how-to/calibrate-a-head.md. */
#define SCENE_THERMAL_COEFF_SD_MM_PER_C 0.001
/* The offsets' random walk beyond the thermal part, µm²/h: a tenth of the estimator's prior
 * (ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT, 576 000, the Allan slope of a recorded VL53L0X lab hour
 * whose temperature nobody measured, docs/explanation/uncertainty.md: an upper bound on what
 * is left once temperature is). An assumption, 0.59 mm 1σ after 6 h; the option sweeps it
 * from 0 to the prior's (1.86 mm after 6 h). */
#define SCENE_THERMAL_WALK_UM2_H 57600.0
/* The unit's temperature reading: an MCU's internal sensor through a 12-bit ADC steps by
 * about 0.3 °C per LSB (2.5 mV/°C at 0.8 mV/LSB, STM32L4 datasheet), and a reading scatters by
 * about that much; modelled as Gaussian noise of this sd, then rounded to the quantum. A bias
 * between the measured and the parts' temperature is not modelled. */
#define SCENE_THERMAL_TEMP_NOISE_C   0.3
#define SCENE_THERMAL_TEMP_QUANTUM_C 0.1

struct scene_thermal {
    bool on;
    double mean_c, amplitude_c; /* T(t) = mean + amplitude · sin(2π t / period + phase) */
    double period_s, phase_deg;
    double cal_temp_c;           /* the temperature the stated offsets hold at */
    double coeff_range_mm_per_c; /* coefficients uniform in ±this, >= 0 */
    double coeff_sd_mm_per_c;    /* the stated coefficients' sd, >= 0 */
    double offset_range_mm;      /* offsets at cal_temp_c uniform in ±this */
    double walk_um2_h;           /* each offset's random walk from 0 at t = 0 */
    double temp_noise_c, temp_quantum_c;
    /* non-empty: the trace names this HEAD.cal (calibration=FILE, relative to the trace)
     * instead of carrying the calibration keys; its writer writes the file */
    char calibration_file[128];
};

/* The drawn head and the walk's state. */
struct scene_thermal_head {
    double offset_mm[SCENE_THERMAL_SENSORS];       /* at cal_temp_c, exact (stated as is) */
    double coeff_mm_per_c[SCENE_THERMAL_SENSORS];  /* the truth */
    double stated_mm_per_c[SCENE_THERMAL_SENSORS]; /* what the trace states: truth + sd · N(0,1) */
    double walk_mm[SCENE_THERMAL_SENSORS];
    struct scene_rng walk_rng, temp_rng;
};

/* The defaults above (on). */
void scene_thermal_defaults(struct scene_thermal *t);

/* NULL when t's parameters are usable, else what is wrong. */
const char *scene_thermal_check(const struct scene_thermal *t);

/* Draws the head from seed (its own streams: other draws of the seed do not shift). */
void scene_thermal_draw(struct scene_thermal_head *h, const struct scene_thermal *t, uint64_t seed);

/* The head's true temperature at time t_s. */
double scene_thermal_temp_c(const struct scene_thermal *t, double t_s);

/*
 * One row at t_s, dt_s after the previous (0 for the first): advances the walks, sets each
 * part's whole offset (stated offset + coefficient · (T − cal_temp) + walk) in offset_mm and
 * the temperature the unit measures in *measured_c; *true_c (may be NULL) the true one.
 */
void scene_thermal_row(struct scene_thermal_head *h, const struct scene_thermal *t, double t_s,
                       double dt_s, double offset_mm[SCENE_THERMAL_SENSORS], double *measured_c,
                       double *true_c);

#endif /* SCENE_THERMAL_H */
