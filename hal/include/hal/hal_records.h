/*
 * Record storage: non-volatile pages that keep what must survive a reset or a
 * power loss (docs/explanation/architecture.md). A const ops struct plus a context pointer, as the
 * I²C interface (hal_i2c.h), with the geometry in the handle.
 *
 * The rules are those of NOR flash with ECC (the STM32L4's, RM0351 §3.3): a page
 * is erased as a whole to all ones (`erased_byte`), and only erased memory may be
 * programmed, in whole granules (`program_granule` bytes, aligned). Programming a
 * granule twice, or partly, is refused; an interrupted write can leave a granule
 * that reads back as an uncorrectable ECC error. Users make their data robust
 * against that (firmware/record.h: two copies, a CRC, a sequence number).
 */
#ifndef HAL_RECORDS_H
#define HAL_RECORDS_H

#include <stddef.h>
#include <stdint.h>

struct hal_records_geometry {
    uint32_t page_size;      /* bytes per page, a multiple of program_granule */
    uint16_t page_count;     /* pages 0 .. page_count-1 belong to the records */
    uint8_t program_granule; /* bytes programmed at once, aligned to their size (8 on STM32L4) */
    uint8_t erased_byte;     /* the value every byte of an erased page reads (0xFF) */
};

struct hal_records_ops {
    /* Copy `len` bytes at `offset` of `page` into `out`. HAL_OK; HAL_ERR_INVALID for a
     * range outside the page; HAL_ERR_CORRUPT when the memory reported an uncorrectable
     * error (ECC double error) in the range: `out` then holds what was read. */
    int (*read)(void *ctx, uint16_t page, uint32_t offset, uint8_t *out, size_t len);
    /* Erase `page` to erased_byte. HAL_OK; HAL_ERR_INVALID for a page out of range;
     * HAL_ERR_TIMEOUT when the memory stayed busy past its bound; HAL_ERR_DEVICE when it
     * reported an error (write protection, sequence error). NULL when erase_start and
     * erase_poll below are given (a user then waits by polling). */
    int (*erase)(void *ctx, uint16_t page);
    /* Program `len` bytes of `data` at `offset` of `page`. `offset` and `len` must be
     * multiples of program_granule (HAL_ERR_INVALID otherwise, nothing written), and the
     * granules must be erased: a granule that is not fails with HAL_ERR_DEVICE, as the
     * memory reports it (granules before it are programmed). HAL_ERR_TIMEOUT as erase. */
    int (*program)(void *ctx, uint16_t page, uint32_t offset, const uint8_t *data, size_t len);
    /* Optional (NULL: only the blocking erase above; one of the two ways is given). Start erasing
     * `page` and return at once: HAL_OK, or erase's errors (nothing started). erase_poll() then
     * returns HAL_ERR_NOT_READY while it runs, HAL_OK once it ended well, erase's errors else (and
     * HAL_OK when no erase was started). No other op may be called in between. What lets
     * a record save go on across main-loop iterations instead of blocking ~22 ms a page. */
    int (*erase_start)(void *ctx, uint16_t page);
    int (*erase_poll)(void *ctx);
};

struct hal_records {
    const struct hal_records_ops *ops; /* NULL: the board has no record storage */
    void *ctx;
    struct hal_records_geometry geometry;
};

#endif /* HAL_RECORDS_H */
