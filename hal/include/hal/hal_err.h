/*
 * One error convention for hal/, drivers/ and firmware/: 0 is success, a
 * negative value names the failure, and callers pass it up unchanged.
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
};

/* Short constant name of an error code, for logs ("ADDR_NACK"); never NULL. */
const char *hal_err_name(int err);

#endif /* HAL_ERR_H */
