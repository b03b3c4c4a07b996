/*
 * One error convention for hal/, drivers/ and firmware/: 0 is success, a
 * negative value names the failure, and callers pass it up unchanged.
 *
 * Every module that returns error codes owns a block of negative numbers no other
 * module uses, so a code names its failure whoever passes it up (docs/reference/errors.md).
 * The estimator does not include hal/, so this table and docs/reference/errors.md are where the
 * blocks are written down; tests/firmware/test_error_convention.c checks them:
 *
 *     -1 ..  -31   hal_err (this file): hal/, drivers/, firmware/, sim/, boards/
 *    -32 ..  -47   enum window_error    (estimator/window_stats.h)
 *    -48 ..  -63   enum kalman_error    (estimator/kalman.h)
 *    -64 ..  -79   enum attitude_error  (estimator/attitude.h)
 *    -80 .. -95    pose_err: the camera pose pipeline (pose/, host only)
 *    -96 .. -128   free (a nack carries a code in an i8: nothing below -128)
 */
#ifndef HAL_ERR_H
#define HAL_ERR_H

enum hal_err {
    HAL_OK = 0,
    HAL_ERR_ADDR_NACK = -1,   /* no device acknowledged its address */
    HAL_ERR_DATA_NACK = -2,   /* device acknowledged the address, then NACKed a data byte */
    HAL_ERR_BUS_BUSY = -3,    /* arbitration lost or bus held busy by another master */
    HAL_ERR_TIMEOUT = -4,     /* a bounded wait ran out of its time budget */
    HAL_ERR_INVALID = -5,     /* argument out of range or inconsistent configuration */
    HAL_ERR_BUS_STUCK = -6,   /* SDA held low; recovery needed */
    HAL_ERR_ID_MISMATCH = -7, /* device answered with the wrong identity */
    HAL_ERR_NOT_READY = -8,   /* device not booted / no data yet (a state, not a fault) */
    HAL_ERR_STATE = -9,       /* call not allowed in the current state */
    HAL_ERR_CORRUPT = -10,    /* data failed a plausibility or integrity check */
    HAL_ERR_IO = -11,         /* other I/O failure (file, UART) */
    HAL_ERR_DEVICE = -12,     /* the device reported a fault of its own (e.g. VL53 hardware fail) */
    /* A new code goes here, next to the last, and HAL_ERR_LAST moves to it. */
};

/* The last (most negative) hal code: the codes are -1..HAL_ERR_LAST, every one named. */
#define HAL_ERR_LAST HAL_ERR_DEVICE
/* How many hal codes there are; a table with a slot per code is sized from it. */
#define HAL_ERR_COUNT (-(int)HAL_ERR_LAST)
/* The most negative number of the hal block (the table above); HAL_ERR_LAST stays above. */
#define HAL_ERR_BLOCK_END (-31)

/* Short constant name of an error code, for logs ("ADDR_NACK"); never NULL. */
const char *hal_err_name(int err);

#endif /* HAL_ERR_H */
