/*
 * 6-DoF pose of a target carrying circular reflectors, from one ToF camera frame
 * (Zhu et al. 2022, ../shared/seeds/001_*.txt). The pipeline:
 *
 *   1. extraction (§3): raw gray threshold -> active pixel set capped at
 *      active_cap pixels (the dimmest dropped) -> negative Laplacian-of-Gaussian
 *      on active pixels only -> second threshold -> connected components with
 *      size, brightness, filter-response and eccentricity criteria ->
 *      intensity-weighted centroids, blob range = mean over member pixels;
 *      ellipse confirmation when the count does not match the catalog;
 *   2. matching (§4): deterministic annealing on pairwise distances (pose_match.h);
 *   3. pose (§5): weighted SVD with the reflection guard, then the line-of-sight
 *      reprojection refinement until the change falls below a threshold.
 *
 * All memory is inside struct pose_pipeline (no heap); see pose_pipeline_sizes().
 */
#ifndef POSE_POSE_H
#define POSE_POSE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "pose/pose_match.h"
#include "pose/pose_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* nLoG kernel half-width: a (2R+1)^2 kernel; 3 sigma must fit, so sigma <= R / 3. */
#define POSE_NLOG_MAX_RADIUS 4
#define POSE_NLOG_MAX_SIZE   (2 * POSE_NLOG_MAX_RADIUS + 1)

struct pose_config {
    /* --- extraction (paper §3.1-3.2) --- */
    uint16_t gray_full_scale; /* largest valid gray value (EPC660: 12-bit, 4095) */
    uint16_t gray_threshold;  /* T_g: raw gray threshold of the active set */
    uint32_t active_cap;      /* N_max of the active set; dimmest pixels dropped past it */
    float nlog_sigma_px;      /* Gaussian sigma of the nLoG filter (Eq. 13) */
    float nlog_keep;          /* second threshold: pixels with response below are dropped */
    float nlog_peak;          /* a blob needs one pixel with response >= this */
    uint16_t gray_peak;       /* a blob needs one pixel with gray >= this */
    uint32_t blob_min_pixels; /* component size limits (paper criterion 3) */
    uint32_t blob_max_pixels;
    float min_axis_ratio;      /* minor / major axis of the moment ellipse; below = eccentric */
    uint32_t shape_min_pixels; /* smaller blobs are too coarse for any shape criterion */
    /* ellipse confirmation (documented simplification of §3.3, see pose_extract.c) */
    float ellipse_rim_tolerance;  /* |normalised rim radius - 1| allowed */
    float ellipse_rim_fraction;   /* share of rim points that must lie on the ellipse */
    float ellipse_area_tolerance; /* |pixel area / moment-ellipse area - 1| allowed */
    uint32_t ellipse_min_pixels;  /* smaller blobs cannot be judged and pass */
    float readmit_min_axis_ratio; /* eccentric blobs confirmed as ellipses return above this */

    /* --- 3-D points for matching --- */
    float centroid_sigma_floor_px; /* centroid standard error: sqrt(floor^2 + one_px^2 / pixels) */
    float centroid_sigma_one_px;
    float depth_spread_mm;      /* prior spread of marker depths about their median */
    float range_sigma_fraction; /* range standard error of a one-pixel blob, fraction of range */
    float range_floor_mm; /* systematic range error of a blob mean (disc tilt, mixed pixels) */
    struct pose_match_config match;
    /* --- pose (paper §5) --- */
    uint16_t refine_max_iterations;
    bool refine_optimal_translation; /* re-solve t for each R (Lu et al.); false: as the paper */
    float refine_tol_mm;  /* stop when the change still to come (|dt|, rotation x 1 m) is below */
    float reproj_gate_px; /* matches with a larger final reprojection residual are dropped */
    float range_gate_sigmas; /* and those whose range residual exceeds this many standard errors */
    bool fuse_range;         /* after the paper's refinement, fuse measured ranges (see pose.c) */
    uint8_t fuse_max_iterations;
    float loo_gate_sigmas; /* leave-one-out prediction error that drops a match; 0 = off */

    bool perspective_correction; /* correct the circle-centre perspective offset (see pose.c) */
};

/* Why a component was not accepted as a candidate reflector. */
enum pose_reject {
    POSE_REJECT_NONE = 0,
    POSE_REJECT_SIZE,        /* pixel count outside [blob_min_pixels, blob_max_pixels] */
    POSE_REJECT_DIM,         /* no pixel reaches gray_peak or nlog_peak */
    POSE_REJECT_ECCENTRIC,   /* axis ratio below min_axis_ratio and not confirmed as an ellipse */
    POSE_REJECT_NOT_ELLIPSE, /* dropped by ellipse confirmation (count mismatch, not an ellipse) */
    POSE_REJECT_NO_RANGE,    /* no member pixel has a range return */
    POSE_REJECT_BORDER,      /* touches the image border: cut off, its centroid is biased */
    POSE_REJECT_CAPACITY,    /* more accepted blobs than POSE_MAX_OBS: the lightest are dropped */
    POSE_REJECT_COUNT
};

/* One candidate reflector as extracted (before matching). */
struct pose_blob {
    float u_px; /* intensity-weighted centroid (paper Eq. 19) */
    float v_px;
    float range_mean_mm;     /* mean range over member pixels with a return (paper Eq. 20) */
    float range_mm;          /* same pixels weighted by centroid weight: used (pose_extract.c) */
    float range_se_mm;       /* standard error of range_mm */
    float centroid_sigma_px; /* modelled centroid standard error (config centroid_sigma_*) */

    float weight; /* sum of (gray - weight floor) over members */
    uint32_t pixels;
    float axis_ratio;     /* minor / major axis of the moment ellipse */
    float peak_response;  /* largest nLoG response */
    bool ellipse_checked; /* ellipse confirmation ran on it */
    bool ellipse_ok;      /* and confirmed it */
};

enum pose_status {
    POSE_STATUS_OK = 0,       /* >= 4 matches, converged, residuals within the gates */
    POSE_STATUS_DEGRADED,     /* usable with care: only 3 matches, or the iteration bound hit */
    POSE_STATUS_FEW_BLOBS,    /* fewer than 3 candidate reflectors */
    POSE_STATUS_NO_MATCH,     /* fewer than 3 consistent matches */
    POSE_STATUS_DEGENERATE,   /* matched reflectors collinear */
    POSE_STATUS_RESIDUAL,     /* fewer than 3 matches left inside the residual gates */
    POSE_STATUS_IMPLAUSIBLE,  /* the solution turns the plate away from the camera */
    POSE_STATUS_RUN_OVERFLOW, /* filtered active set needed more than POSE_MAX_RUNS runs */
    POSE_STATUS_COUNT
};

/* Short constant name of a status ("OK", "NO_MATCH"); never NULL. */
const char *pose_status_name(enum pose_status status);

struct pose_match_info {
    uint8_t blob;   /* index into pose_result.blobs */
    uint8_t marker; /* catalog index */
    float u_px;     /* centroid after the perspective correction */
    float v_px;
    float reproj_px;    /* final reprojection residual */
    float range_res_mm; /* measured minus predicted range along the line of sight */
};

struct pose_result {
    enum pose_status status;
    float r[3][3]; /* rotation target -> camera (paper's R) */
    float t_mm[3]; /* target origin in the camera frame (paper's T) */
    uint8_t n_blobs;
    struct pose_blob blobs[POSE_MAX_OBS];
    uint8_t n_matches;
    struct pose_match_info matches[POSE_MAX_MARKERS];
    float reproj_rms_px;
    float range_rms_mm;
    float object_rms_mm; /* line-of-sight (object-space) residual, the refined quantity */
    uint16_t refine_iterations;
    uint8_t fuse_iterations;
    uint16_t anneal_steps;
    /* extraction bookkeeping: nothing is dropped without being counted here */
    uint32_t active_pixels; /* size of the active set after the cap */
    uint32_t capped_pixels; /* pixels above the gray threshold dropped by the cap */
    uint16_t cut_level;     /* gray level of the active set after the cap */
    uint32_t kept_pixels;   /* active pixels passing the nLoG threshold */
    uint32_t runs;
    uint16_t components;                  /* connected components found */
    uint16_t components_lost;             /* beyond POSE_MAX_COMPONENTS: not examined */
    uint16_t rejected[POSE_REJECT_COUNT]; /* components per enum pose_reject */
    uint8_t dropped_matches;              /* matches dropped by the residual gates */
};

struct pose_run {
    uint16_t y;
    uint16_t x0;
    uint16_t x1;
    uint16_t link;       /* union-find parent while labelling */
    float peak_response; /* largest nLoG response in the run */
};

struct pose_component {
    uint32_t pixels;
    uint16_t x_origin; /* moments are accumulated relative to the first run's start */
    uint16_t y_origin;
    uint16_t gray_max;
    float peak_response;
    uint64_t w; /* exact integer sums of w, w x, w y, w x^2, w y^2, w x y */
    int64_t wx;
    int64_t wy;
    int64_t wxx;
    int64_t wyy;
    int64_t wxy;
    uint16_t range_ref; /* first member range; sums below are of (range - range_ref) in mm */
    int64_t range_sum;
    int64_t range_sq_sum;
    uint32_t range_count; /* member pixels with a return */
    uint64_t range_w;     /* sums of w, w^2 and w (range - range_ref) over those pixels */
    uint64_t range_w2;
    int64_t range_wsum;
    float axis_ratio;
    bool touches_border;
    enum pose_reject reject;

    bool ellipse_checked;
    bool ellipse_ok;
};

/* Everything the pipeline works in, excluding the caller's frame buffers. */
struct pose_workspace {
    struct pose_run runs[POSE_MAX_RUNS];
    uint8_t run_component[POSE_MAX_RUNS];
    struct pose_component components[POSE_MAX_COMPONENTS];
    uint32_t histogram[64];
    float nlog_kernel[POSE_NLOG_MAX_SIZE][POSE_NLOG_MAX_SIZE];
    int nlog_radius;
    struct pose_match_obs obs[POSE_MAX_OBS];
    int8_t assignment[POSE_MAX_OBS];
    struct pose_match_work match;
};

struct pose_pipeline {
    struct pose_config cfg;
    struct pose_camera cam;
    struct pose_marker markers[POSE_MAX_MARKERS];
    uint8_t n_markers;
    struct pose_workspace ws;
};

/* Defaults tuned on the synthetic camera for the paper's target (values explained in pose.c). */
void pose_config_default(struct pose_config *cfg);

/* The paper's target: eight reflectors in two L-shaped groups (layout in pose_target.c). */
extern const struct pose_marker pose_paper_target[8];
#define POSE_PAPER_TARGET_COUNT 8u

/* The paper's camera: EPC660 (320 x 240) behind a 6.5 mm lens, HFOV 52.4 deg, VFOV 40.6 deg. */
void pose_camera_paper(struct pose_camera *cam);

/*
 * Checks the configuration, camera and catalog (2..POSE_MAX_MARKERS markers) and
 * prepares the pipeline. Returns POSE_OK or POSE_ERR_INVALID.
 */
int pose_init(struct pose_pipeline *p, const struct pose_config *cfg, const struct pose_camera *cam,
              const struct pose_marker *markers, size_t n_markers);

/*
 * Stage 1 only: fills out->blobs and the extraction counters. Returns POSE_OK, or
 * POSE_ERR_FRAME (size differs from the camera, or a gray value above full
 * scale: *bad_x, *bad_y name the pixel, may be NULL), POSE_ERR_INVALID.
 */
int pose_extract(struct pose_pipeline *p, const struct pose_frame *frame, struct pose_result *out,
                 uint16_t *bad_x, uint16_t *bad_y);

/*
 * The full pipeline on one frame. Returns POSE_OK when the frame was processed
 * (out->status says whether the pose is usable) or a negative pose_err as
 * pose_extract.
 */
int pose_process(struct pose_pipeline *p, const struct pose_frame *frame, struct pose_result *out,
                 uint16_t *bad_x, uint16_t *bad_y);

/*
 * Pose from already matched reflectors (stages 3): marker_idx[k] is the catalog
 * index of blob k of `blobs`. Used by pose_process and exposed for tests.
 */
int pose_solve(struct pose_pipeline *p, const struct pose_blob *blobs, const uint8_t *blob_idx,
               const uint8_t *marker_idx, size_t n, struct pose_result *out);

#ifdef __cplusplus
}
#endif

#endif /* POSE_POSE_H */
