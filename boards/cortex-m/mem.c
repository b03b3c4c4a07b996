/* The C library's memory functions written small, for a Cortex-M image whose flash budget needs it:
 * byte loops of a few instructions each where newlib-nano's word-copying ones take 484 (memcpy),
 * 176 (memmove) and 166 B (memset) of the M0+ image's 64 KiB flight budget. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* The loops are not turned back into calls to these functions (GCC's loop-distribution pass
 * recognises copy and fill loops), which here would be each calling itself. */
#define TOF_NO_LIBCALL __attribute__((optimize("no-tree-loop-distribute-patterns")))

/* Copied forwards, as memmove does for the regions memcpy may be given (they do not overlap). */
TOF_NO_LIBCALL void *memcpy(void *restrict dst, const void *restrict src, size_t n) {
    return memmove(dst, src, n);
}

/* Overlapping regions: copied forwards when the destination is below the source, else
 * backwards, so no byte is read after it was overwritten. */
TOF_NO_LIBCALL void *memmove(void *dst, const void *src, size_t n) {
    unsigned char *d = dst;
    const unsigned char *s = src;
    if ((uintptr_t)d < (uintptr_t)s) {
        for (size_t i = 0; i < n; ++i) {
            d[i] = s[i];
        }
    } else {
        for (size_t i = n; i > 0u; --i) {
            d[i - 1u] = s[i - 1u];
        }
    }
    return dst;
}

TOF_NO_LIBCALL void *memset(void *dst, int value, size_t n) {
    unsigned char *d = dst;
    for (size_t i = 0; i < n; ++i) {
        d[i] = (unsigned char)value;
    }
    return dst;
}
