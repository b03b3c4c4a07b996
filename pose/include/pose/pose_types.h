/*
 * Shared types of the camera pose module (Zhu et al. 2022, "System
 * Design for Pose Determination of Spacecraft Using Time-of-Flight Sensors",
 * ../shared/seeds/001_*.txt): error codes, camera intrinsics, frames and the
 * reflector catalog.
 *
 * This module is the one part of estimator/ that uses single-precision float
 * (it targets an FPU core, as the paper's camera does). It never uses double,
 * allocates nothing and bounds every loop.
 *
 * Frames: the camera frame has x right, y down, z along the boresight; pixel
 * (u, v) = (column, row) has its centre at integer coordinates. The target
 * (catalog) frame has its origin on the plate surface, z out of the plate.
 * Distances are millimetres.
 */
#ifndef POSE_POSE_TYPES_H
#define POSE_POSE_TYPES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Capacities: every buffer of the pipeline is sized by these. */
#define POSE_MAX_MARKERS    16u   /* catalog entries */
#define POSE_MAX_OBS        16u   /* candidate reflectors passed to matching */
#define POSE_MAX_COMPONENTS 64u   /* connected components examined per frame */
#define POSE_MAX_RUNS       2048u /* horizontal pixel runs of the filtered active set */
#define POSE_MAX_WIDTH      1024u /* frame width limit (run coordinates are 16-bit) */
#define POSE_MAX_HEIGHT     1024u

/* Errors: 0 success, negative values name the failure (one convention, passed up); the
 * block -80..-95 is pose's (docs/reference/errors.md). */
enum pose_err {
    POSE_OK = 0,
    POSE_ERR_INVALID = -80,    /* NULL argument or inconsistent configuration */
    POSE_ERR_FRAME = -81,      /* frame size or pixel value outside what was configured */
    POSE_ERR_DEGENERATE = -82, /* point set cannot define a rotation (collinear, too few) */
    POSE_ERR_NO_CONVERGE = -83 /* an iterative solver hit its iteration bound */
};

/* Short constant name of an error code ("INVALID"); never NULL. */
const char *pose_err_name(int err);

/* Pinhole intrinsics (paper Eq. 7): u = fx * x/z + cx, v = fy * y/z + cy. */
struct pose_camera {
    uint16_t width;  /* pixels per row */
    uint16_t height; /* rows */
    float fx_px;     /* focal length in pixels, x */
    float fy_px;     /* focal length in pixels, y */
    float cx_px;     /* principal point, pixel coordinates */
    float cy_px;
};

/*
 * One gray + depth frame as the ToF camera delivers it (paper §2.1: the same
 * shot gives an intensity and a range image). Row-major, `stride` elements per
 * row. gray: raw intensity, 0..full scale. range_mm: distance along the pixel's
 * line of sight in millimetres (a radial range, as phase ToF measures), 0 =
 * no return.
 */
struct pose_frame {
    const uint16_t *gray;
    const uint16_t *range_mm;
    uint16_t width;
    uint16_t height;
    uint16_t stride;
};

/* One circular reflector of the target: centre in the target frame, disc parallel to the plate. */
struct pose_marker {
    float position_mm[3];
    float diameter_mm;
};

#ifdef __cplusplus
}
#endif

#endif /* POSE_POSE_TYPES_H */
