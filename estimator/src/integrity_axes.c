/* The axes as least-squares combinations of the sensor means over a set of sensors. */
#include <string.h>

#include "integrity_internal.h"

/* docs/explanation/architecture.md: α needs A and C (y = (x_C − x_A)/2), or one of them with B and
 * D (their midpoint stands for x̄); β likewise. */
int integrity_axis_coeffs(enum integrity_axis axis, uint8_t used, int8_t c[ANGLES_SENSORS]) {
    static const int8_t table[9][ANGLES_SENSORS] = {
        {-1, 0, 1, 0}, {0, -1, 2, -1}, {-2, 1, 0, 1}, /* α: A+C, C+B+D, A+B+D */
        {0, 1, 0, -1}, {-1, 2, -1, 0}, {1, 0, 1, -2}, /* β: B+D, A+B+C, A+C+D */
        {1, 1, 1, 1},  {2, 0, 2, 0},   {0, 2, 0, 2},  /* x̄: all, A+C, B+D */
    };
    const bool a = (used & ANGLES_BIT(ANGLES_A)) != 0u;
    const bool b = (used & ANGLES_BIT(ANGLES_B)) != 0u;
    const bool cc = (used & ANGLES_BIT(ANGLES_C)) != 0u;
    const bool d = (used & ANGLES_BIT(ANGLES_D)) != 0u;
    int row = -1;
    int unit = 1;
    if (axis == INTEGRITY_ALPHA) {
        if (a && cc) {
            row = 0;
        } else if (cc && b && d) {
            row = 1;
        } else if (a && b && d) {
            row = 2;
        } else {
            row = -1;
        }
    } else if (axis == INTEGRITY_BETA) {
        if (b && d) {
            row = 3;
        } else if (a && b && cc) {
            row = 4;
        } else if (a && cc && d) {
            row = 5;
        } else {
            row = -1;
        }
    } else {
        unit = 2;
        if (a && b && cc && d) {
            row = 6;
        } else if (a && cc) {
            row = 7;
        } else if (b && d) {
            row = 8;
        } else {
            row = -1;
        }
    }
    if (row < 0) {
        return -1;
    }
    (void)memcpy(c, table[row], sizeof table[row]);
    return unit;
}

bool integrity_axis_var(enum integrity_axis axis, uint8_t used, const fix_q32_t v[ANGLES_SENSORS],
                        fix_q32_t *var_mm2) {
    int8_t c[ANGLES_SENSORS];
    const int unit = integrity_axis_coeffs(axis, used, c);
    *var_mm2 = 0;
    if (unit < 0) {
        return false;
    }
    fix_q32_t sum = 0;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        sum = fix_sat_add_s64(sum, fix_sat_mul_s64(v[k], (int64_t)c[k] * c[k]));
    }
    *var_mm2 = fix_asr_s64(sum, 2u * (unsigned)unit);
    return true;
}

void integrity_axes_coeffs(uint8_t used, struct integrity_axes_coeffs *ac) {
    for (unsigned ax = 0; ax < INTEGRITY_AXES; ++ax) {
        ac->unit[ax] = integrity_axis_coeffs((enum integrity_axis)ax, used, ac->c[ax]);
    }
}
