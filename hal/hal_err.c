/* The names of the hal error codes, for logs. */
#include "hal/hal_err.h"

const char *hal_err_name(int err) {
    switch (err) {
    case HAL_OK:
        return "OK";
    case HAL_ERR_ADDR_NACK:
        return "ADDR_NACK";
    case HAL_ERR_DATA_NACK:
        return "DATA_NACK";
    case HAL_ERR_BUS_BUSY:
        return "BUS_BUSY";
    case HAL_ERR_TIMEOUT:
        return "TIMEOUT";
    case HAL_ERR_INVALID:
        return "INVALID";
    case HAL_ERR_BUS_STUCK:
        return "BUS_STUCK";
    case HAL_ERR_ID_MISMATCH:
        return "ID_MISMATCH";
    case HAL_ERR_NOT_READY:
        return "NOT_READY";
    case HAL_ERR_STATE:
        return "STATE";
    case HAL_ERR_CORRUPT:
        return "CORRUPT";
    case HAL_ERR_IO:
        return "IO";
    case HAL_ERR_DEVICE:
        return "DEVICE";
    default:
        return "UNKNOWN";
    }
}
