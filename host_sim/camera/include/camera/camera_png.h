/* Minimal PNG writer (8-bit RGB, zlib "stored" blocks: no compression library needed). */
#ifndef CAMERA_CAMERA_PNG_H
#define CAMERA_CAMERA_PNG_H

#include <stdint.h>

/*
 * Writes width x height RGB pixels (row-major, 3 bytes each) to path. Returns 0,
 * or -1 with errno set by the failing stdio call.
 */
int camera_png_write(const char *path, const uint8_t *rgb, int width, int height);

#endif /* CAMERA_CAMERA_PNG_H */
