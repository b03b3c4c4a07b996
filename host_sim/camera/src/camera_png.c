/*
 * PNG encoder for the camera's --image output: signature, IHDR, one IDAT holding
 * a zlib stream of uncompressed ("stored") deflate blocks, IEND. Formats from
 * RFC 1950 (zlib), RFC 1951 §3.2.4 (stored blocks) and the PNG specification
 * (ISO/IEC 15948, chunk layout and CRC-32).
 */
#include "camera/camera_png.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t crc_table[256];
static int crc_ready;

static void crc_init(void) {
    for (uint32_t n = 0; n < 256u; ++n) {
        uint32_t c = n;
        for (int k = 0; k < 8; ++k) {
            c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        }
        crc_table[n] = c;
    }
    crc_ready = 1;
}

static uint32_t crc_update(uint32_t crc, const uint8_t *buf, size_t len) {
    for (size_t i = 0; i < len; ++i) {
        crc = crc_table[(crc ^ buf[i]) & 0xFFu] ^ (crc >> 8);
    }
    return crc;
}

static void put_be32(uint8_t *p, uint32_t v) {
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

static int write_chunk(FILE *f, const char type[4], const uint8_t *data, size_t len) {
    uint8_t head[8];
    put_be32(head, (uint32_t)len);
    memcpy(head + 4, type, 4);
    uint32_t crc = crc_update(0xFFFFFFFFu, head + 4, 4);
    crc = crc_update(crc, data, len) ^ 0xFFFFFFFFu;
    uint8_t tail[4];
    put_be32(tail, crc);
    if (fwrite(head, 1, 8, f) != 8 || (len > 0 && fwrite(data, 1, len, f) != len) ||
        fwrite(tail, 1, 4, f) != 4) {
        return -1;
    }
    return 0;
}

int camera_png_write(const char *path, const uint8_t *rgb, int width, int height) {
    if (!crc_ready) {
        crc_init();
    }
    size_t row = (size_t)width * 3u + 1u; /* filter byte 0 + RGB */
    size_t raw_len = row * (size_t)height;
    size_t blocks = (raw_len + 65534u) / 65535u;
    size_t z_len = 2u + raw_len + blocks * 5u + 4u;
    uint8_t *z = malloc(z_len);
    uint8_t *raw = malloc(raw_len);
    if (z == NULL || raw == NULL) {
        free(z);
        free(raw);
        return -1;
    }
    for (int y = 0; y < height; ++y) {
        raw[(size_t)y * row] = 0;
        memcpy(raw + (size_t)y * row + 1u, rgb + (size_t)y * (size_t)width * 3u,
               (size_t)width * 3u);
    }
    size_t o = 0;
    z[o++] = 0x78; /* CM = 8 (deflate), 32 KiB window */
    z[o++] = 0x01; /* FCHECK so that (0x78 << 8 | 0x01) % 31 == 0, no dictionary */
    for (size_t pos = 0; pos < raw_len;) {
        size_t n = raw_len - pos > 65535u ? 65535u : raw_len - pos;
        z[o++] = (pos + n == raw_len) ? 1u : 0u; /* BFINAL, BTYPE = 00 stored */
        z[o++] = (uint8_t)n;
        z[o++] = (uint8_t)(n >> 8);
        z[o++] = (uint8_t)~n;
        z[o++] = (uint8_t)(~n >> 8);
        memcpy(z + o, raw + pos, n);
        o += n;
        pos += n;
    }
    uint32_t a = 1, b = 0; /* Adler-32 of the uncompressed data (RFC 1950 §8.2) */
    for (size_t i = 0; i < raw_len; ++i) {
        a = (a + raw[i]) % 65521u;
        b = (b + a) % 65521u;
    }
    put_be32(z + o, (b << 16) | a);
    o += 4;

    uint8_t ihdr[13];
    put_be32(ihdr, (uint32_t)width);
    put_be32(ihdr + 4, (uint32_t)height);
    ihdr[8] = 8;  /* bit depth */
    ihdr[9] = 2;  /* colour type: truecolour */
    ihdr[10] = 0; /* deflate */
    ihdr[11] = 0; /* adaptive filtering */
    ihdr[12] = 0; /* no interlace */
    static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    int rc = -1;
    FILE *f = fopen(path, "wb");
    if (f != NULL) {
        if (fwrite(sig, 1, 8, f) == 8 && write_chunk(f, "IHDR", ihdr, 13) == 0 &&
            write_chunk(f, "IDAT", z, o) == 0 && write_chunk(f, "IEND", NULL, 0) == 0) {
            rc = 0;
        }
        if (fclose(f) != 0) {
            rc = -1;
        }
    }
    free(z);
    free(raw);
    return rc;
}
