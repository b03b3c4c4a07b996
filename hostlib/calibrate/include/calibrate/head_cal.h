/*
 * The head-calibration file v1 (docs/reference/calibration-file.md,
 * docs/how-to/calibrate-a-head.md): reader and writer.
 *
 *   # tof-head-cal v1
 *   # offset_mm=-3.105,7.882,0.516,-12.340
 *   # offset_sd_mm=0.028,0.029,0.028,0.030
 *   # gain=1.00410,0.99187,1.01202,0.99655
 *   # gain_sd=0.00019,0.00020,0.00019,0.00021
 *
 *   # cal_temp_c=24.87
 *   # temp_coeff_mm_per_c=0.006702,0.025991,-0.013190,-0.008811
 *   # temp_coeff_sd_mm_per_c=0.000412,0.000405,0.000411,0.000409
 *
 * Four values each, sensors A, B, C, D, in the sense raw = gain · true + offset; at
 * temperature T the offset is offset + temp_coeff · (T − cal_temp_c).
 * offset_mm and offset_sd_mm are required; gain and gain_sd come together or not at all; the
 * three thermal keys (cal_temp_c one value, the head's) likewise.
 * Keys this reader does not know are kept (head_cal_extra) and otherwise ignored. The
 * same keys may stand inline in a trace's metadata: head_cal_key() takes them one by one
 * from any source, head_cal_finish() checks what must be there.
 */
#ifndef CALIBRATE_HEAD_CAL_H
#define CALIBRATE_HEAD_CAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#define HEAD_CAL_SENSORS   4u
#define HEAD_CAL_ERR_MAX   512u
#define HEAD_CAL_NAME_MAX  256u
#define HEAD_CAL_MAX_KEYS  32u /* every key=value line, the four above included */
#define HEAD_CAL_KEY_MAX   32u
#define HEAD_CAL_VALUE_MAX 128u /* a trace's metadata value must fit too (TRACE_VALUE_MAX) */

struct head_cal {
    double offset_mm[HEAD_CAL_SENSORS];    /* raw = gain · true + offset */
    double offset_sd_mm[HEAD_CAL_SENSORS]; /* 1 sd of the calibration's own error, >= 0 */
    bool has_gain;                         /* false: gain 1, its sd the parts' stated spread */
    double gain[HEAD_CAL_SENSORS];         /* 1 when !has_gain */
    double gain_sd[HEAD_CAL_SENSORS];      /* 0 when !has_gain */
    bool thermal;                          /* the three thermal keys given */
    double cal_temp_c;                     /* where offset_mm holds, °C */
    double temp_coeff_mm_per_c[HEAD_CAL_SENSORS];    /* d offset / dT */
    double temp_coeff_sd_mm_per_c[HEAD_CAL_SENSORS]; /* its 1 sd, >= 0 */
    /* every key=value read, in order (the four above included), for the project's keys */
    unsigned count;
    char key[HEAD_CAL_MAX_KEYS][HEAD_CAL_KEY_MAX];
    char value[HEAD_CAL_MAX_KEYS][HEAD_CAL_VALUE_MAX];
    unsigned line[HEAD_CAL_MAX_KEYS];
    bool checksummed; /* the file ends with its checksum line, which matched */
};

/* Where keys come from, for messages: "name:line:col: what". */
struct head_cal_reader {
    struct head_cal cal;
    char name[HEAD_CAL_NAME_MAX];
    bool seen[7]; /* offset_mm, offset_sd_mm, gain, gain_sd, and the three thermal keys */
    unsigned seen_line[7];
    char err[HEAD_CAL_ERR_MAX];
};

/* Starts collecting keys; name is the file (or trace) named in messages. */
void head_cal_begin(struct head_cal_reader *r, const char *name);

/*
 * One key=value (value without surrounding blanks), from line `line`, the value starting
 * at column `col` (1-based; 0 when unknown: the message then names the line only).
 * Checks the four known keys: exactly four finite comma-separated decimals, sd >= 0,
 * gain > 0; a repeated key is an error. Returns 0, or -1 with the message in r->err.
 */
int head_cal_key(struct head_cal_reader *r, const char *key, const char *value, unsigned line,
                 unsigned col);

/* After the last key: offset_mm and offset_sd_mm present, gain and gain_sd together, the
 * thermal keys all three or none. Fills r->cal (gain 1, gain_sd 0 without gain keys; thermal
 * false without the thermal keys). Returns 0, or -1 with r->err. */
int head_cal_finish(struct head_cal_reader *r);

/*
 * Reads a HEAD.cal from the len bytes at text (name for messages): the first line
 * "# tof-head-cal v1" (a UTF-8 byte-order mark and CRLF endings are accepted), then
 * "# key=value" lines, comment lines ("# text" without '=') and blank lines; anything
 * else is an error. The last line "# checksum=crc32:XXXXXXXX" (8 lowercase hex digits) is
 * the CRC-32 (IEEE 802.3, as zlib's crc32) of every byte before it: a mismatch, or anything
 * but blank lines after it, is an error (the file was cut or edited). A file without that
 * line (written before checksums) is read as it stands, cal->checksummed false; one whose
 * last line has no line end is an error either way (cut). Returns 0 with *cal filled, or -1
 * with "name:line:col: what" in err.
 */
int head_cal_parse(const char *text, size_t len, const char *name, struct head_cal *cal, char *err,
                   size_t errlen);

/* head_cal_parse of the file at path; a file without a checksum line gets a warning on
 * stderr saying how it is read. Returns 0, or -1 with the message in err. */
int head_cal_load(const char *path, struct head_cal *cal, char *err, size_t errlen);

/* Value of key in cal (NULL if absent), e.g. the project's keys (docs/how-to/calibrate-a-head.md).
 */
const char *head_cal_extra(const struct head_cal *cal, const char *key);

/*
 * Writes cal as a HEAD.cal: the version line, offset_mm, offset_sd_mm, gain, gain_sd
 * when cal->has_gain, cal_temp_c, temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c when cal->thermal
 * (the temperature to 0.01 °C, the coefficients to 1e-6 mm/°C, the keys' units), with enough digits
 * to read back the same to 1e-9 relative; then each "key=value" of extra (NULL-terminated, may be
 * NULL). Returns 0, or -1 on a write error or an extra entry that is not key=value within the sizes
 * above.
 */
int head_cal_write(FILE *f, const struct head_cal *cal, const char *const *extra);

#endif /* CALIBRATE_HEAD_CAL_H */
