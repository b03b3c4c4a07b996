/* The C library's memory and string functions of the flight images, written small: newlib-nano's
 * take 308 (memcpy), 254 (memmove), 162 (memset) and 220 B (strlen) of the M4 image's 64 KiB
 * flight budget. Words where both pointers are word-aligned (the structs the firmware copies and
 * clears: a boot's memset of the application's 8 KB stays as fast), bytes otherwise. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* The loops are not turned back into calls to these functions (GCC's loop-distribution pass
 * recognises copy and fill loops), which here would be each calling itself. */
#define TOF_NO_LIBCALL __attribute__((optimize("no-tree-loop-distribute-patterns")))

/* A word that may alias any object: the copies read and write other types' bytes through it. */
typedef uint32_t __attribute__((may_alias)) mem_word_t;

#define MEM_WORD 4u

static int both_aligned(const void *a, const void *b) {
    return (((uintptr_t)a | (uintptr_t)b) & (MEM_WORD - 1u)) == 0u;
}

/* Forwards: safe when the destination is below the source or the regions do not overlap (a
 * word is read whole before it is written, and aligned regions that overlap are at least a
 * word apart). One function for memcpy and memmove: memcpy may not call memmove, which GCC
 * turns back into memcpy for restrict pointers (a call to itself). */
TOF_NO_LIBCALL static void copy_forward(unsigned char *d, const unsigned char *s, size_t n) {
    const size_t words = both_aligned(d, s) ? n / MEM_WORD : 0u;
    for (size_t w = 0; w < words; ++w) {
        ((mem_word_t *)(void *)d)[w] = ((const mem_word_t *)(const void *)s)[w];
    }
    for (size_t i = words * MEM_WORD; i < n; ++i) {
        d[i] = s[i];
    }
}

TOF_NO_LIBCALL void *memcpy(void *restrict dst, const void *restrict src, size_t n) {
    copy_forward(dst, src, n);
    return dst;
}

/* Overlapping regions: forwards when the destination is below the source, else backwards,
 * so no byte is read after it was overwritten. */
TOF_NO_LIBCALL void *memmove(void *dst, const void *src, size_t n) {
    unsigned char *d = dst;
    const unsigned char *s = src;
    if ((uintptr_t)d < (uintptr_t)s) {
        copy_forward(d, s, n);
        return dst;
    }
    const size_t words = both_aligned(d, s) ? n / MEM_WORD : 0u;
    for (size_t i = n; i > words * MEM_WORD; --i) {
        d[i - 1u] = s[i - 1u];
    }
    for (size_t w = words; w > 0u; --w) {
        ((mem_word_t *)(void *)d)[w - 1u] = ((const mem_word_t *)(const void *)s)[w - 1u];
    }
    return dst;
}

TOF_NO_LIBCALL void *memset(void *dst, int value, size_t n) {
    unsigned char *d = dst;
    const size_t words = both_aligned(d, d) ? n / MEM_WORD : 0u;
    const uint32_t fill = 0x01010101u * (uint32_t)(unsigned char)value;
    for (size_t w = 0; w < words; ++w) {
        ((mem_word_t *)(void *)d)[w] = fill;
    }
    for (size_t i = words * MEM_WORD; i < n; ++i) {
        d[i] = (unsigned char)value;
    }
    return dst;
}

TOF_NO_LIBCALL size_t strlen(const char *s) {
    size_t n = 0;
    while (s[n] != '\0') {
        ++n;
    }
    return n;
}
