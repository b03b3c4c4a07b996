/* The integrity family's shared arithmetic: a significance test and a square, in 128 bits. */
/* One copy for every file of the family: as inline functions of the family's header each
 * user got its own (170 bytes twice on the Cortex-M0+ image). */
#include "integrity_internal.h"

bool integrity_beyond(fix_q32_t v, fix_q32_t var, uint16_t k_q8) {
    const fix_s128 v2 = fix_s128_mul(v, v); /* Q64 */
    const fix_s128 lim =
        fix_s128_shl(fix_s128_mul((int64_t)k_q8 * (int64_t)k_q8, var), 16u); /* Q64 */
    return fix_s128_cmp(v2, lim) > 0;
}

fix_q32_t integrity_square_q32(fix_q32_t v) {
    return fix_s128_to_s64(fix_s128_shr_round(fix_s128_mul(v, v), FIX_Q32_SHIFT), NULL);
}
