/*
 * The I²C capture format (docs/reference/tools.md, `--i2c-log`): one CSV line per bus transaction,
 * header `t_us,addr,write,read,result`; t_us simulated µs, addr the 7-bit address as 0x29,
 * write / read the bytes as lowercase hex without separators (a register write is the
 * 2-byte big-endian index then the data; a read has the index in `write`, the data in
 * `read`), result `ok` or the error's name (hal_err_name). Integer C writing into the
 * caller's buffer, so host_sim and the twin format their logs the same way.
 */
#ifndef SIM_I2C_CSV_H
#define SIM_I2C_CSV_H

#include <stddef.h>

#include "sim/sim_i2c.h"

/* The header line, without its newline. */
#define SIM_I2C_CSV_HEADER "t_us,addr,write,read,result"

/* Longest line: 20 digits, "0x7f", both directions at SIM_I2C_MAX_TRANSFER bytes, the
 * longest error name, four commas, newline and NUL. */
#define SIM_I2C_CSV_LINE_MAX (20u + 4u + 4u * SIM_I2C_MAX_TRANSFER + 16u + 4u + 2u)

/* Format `t` as one line ending in '\n' into buf[0..cap-1], NUL-terminated. Returns its
 * length without the NUL, or 0 if it does not fit (buf then holds ""). */
size_t sim_i2c_csv_line(const struct sim_i2c_transaction *t, char *buf, size_t cap);

#endif /* SIM_I2C_CSV_H */
