/*
 * Synthetic ToF camera (host only, double precision): renders the gray and
 * range images of the paper's target (black plate, circular reflectors on
 * posts) plus optional spurious bright blobs, with area-coverage supersampling
 * so blob centroids are exact to a few thousandths of a pixel before noise.
 *
 * Model (docs/explanation/pose.md): pinhole camera, no lens distortion; a surface's gray is
 * its reflectance times full scale, independent of range (auto exposure keeps
 * the reflectors near 80 %); a pixel's gray is the coverage-weighted mean of the
 * surfaces it sees; its range is the gray-weighted mean range of those surfaces
 * (a mixed pixel of a phase ToF camera leans toward the brighter return), 0 when
 * nothing returns. Noise: gray N(0, gray_sigma * full scale), range
 * N(0, range_sigma * range) per pixel, both rounded to integers and clamped.
 */
#ifndef CAMERA_CAMERA_H
#define CAMERA_CAMERA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "pose/pose.h"

#define CAMERA_WIDTH        320
#define CAMERA_HEIGHT       240
#define CAMERA_MAX_SPURIOUS 16
#define CAMERA_FULL_SCALE   4095

/* Seeded PRNG (xoshiro256** seeded through splitmix64; Blackman & Vigna 2018). */
struct camera_rng {
    uint64_t s[4];
};
void camera_rng_seed(struct camera_rng *rng, uint64_t seed);
uint64_t camera_rng_next(struct camera_rng *rng);
double camera_rng_uniform(struct camera_rng *rng, double lo, double hi); /* [lo, hi) */
double camera_rng_gauss(struct camera_rng *rng);                         /* N(0, 1) */

struct camera_intrinsics {
    double fx, fy, cx, cy;
};

/* Pose of the target in the camera frame: x_cam = r * x_target + t. */
struct camera_pose {
    double r[3][3];
    double t[3];
};

/* A flat elliptical reflector: centre and axes in the camera frame. */
struct camera_disc {
    double centre[3];
    double normal[3]; /* unit */
    double axis[3];   /* unit, in the disc plane: direction of semi-axis a */
    double a, b;      /* semi-axes, mm */
    double reflectance;
};

struct camera_scene {
    struct camera_pose pose;
    const struct pose_marker *markers;
    size_t n_markers;
    bool hidden[POSE_MAX_MARKERS]; /* marker removed from the scene (occluded, failed) */
    double marker_reflectance;     /* fraction of full scale */
    double plate_reflectance;
    double plate_half_x, plate_half_y; /* plate extent about the target origin, mm */
    size_t n_spurious;
    struct camera_disc spurious[CAMERA_MAX_SPURIOUS];
    int pose_draws; /* rotations drawn by camera_random_scene before one fitted the view */
};

struct camera_noise {
    double gray_sigma;  /* fraction of full scale */
    double range_sigma; /* fraction of range */
};

struct camera_frame {
    uint16_t gray[CAMERA_HEIGHT][CAMERA_WIDTH];
    uint16_t range_mm[CAMERA_HEIGHT][CAMERA_WIDTH];
};

/* Ground truth of one rendered marker. */
struct camera_marker_truth {
    bool in_scene;    /* not hidden */
    bool visible;     /* in the scene, its centre ray hits it, and it lies fully in the image */
    double u, v;      /* image of the disc centre */
    double ue, ve;    /* centre of its image ellipse (what an unbiased centroid finds) */
    double radius_px; /* approximate image radius */
    double range_mm;  /* camera to disc centre */
};

struct camera_truth {
    struct camera_marker_truth markers[POSE_MAX_MARKERS];
    double spurious_u[CAMERA_MAX_SPURIOUS];
    double spurious_v[CAMERA_MAX_SPURIOUS];
    uint32_t supersampled_pixels;
};

/* Intrinsics of the paper's camera (same numbers as pose_camera_paper, in double). */
void camera_paper_intrinsics(struct camera_intrinsics *k);

/* Default scene: the paper's target, reflectance 0.8 / plate 0.06, 440 x 300 mm plate. */
void camera_scene_default(struct camera_scene *scene);

/*
 * Renders one frame. supersample: subsamples per axis in mixed pixels (>= 1);
 * rng may be NULL when both noise terms are 0.
 */
void camera_render(const struct camera_intrinsics *k, const struct camera_scene *scene,
                   const struct camera_noise *noise, int supersample, struct camera_rng *rng,
                   struct camera_frame *frame, struct camera_truth *truth);

/* Rotation from roll (x), pitch (y), yaw (z) in degrees applied to a target facing the camera. */
void camera_pose_from_angles(double roll_deg, double pitch_deg, double yaw_deg, const double t[3],
                             struct camera_pose *pose);

/* Angle between two rotations in degrees. */
double camera_rotation_error_deg(const double a[3][3], const float b[3][3]);

/* ---- random scenes and scoring (camera_scenario.c) ---- */

struct camera_scenario {
    double range_mm;      /* target origin distance along the boresight, +-2 % */
    int spurious;         /* spurious bright blobs per frame */
    int missing;          /* markers hidden per frame */
    double max_angle_deg; /* roll, pitch, yaw each uniform in +-this */
    bool allow_partial;   /* do not require every marker in view (short ranges) */
};

/*
 * Draws a random pose (angles uniform, lateral offset uniform over the offsets
 * that keep every marker, with a 5-pixel margin, in the image), hides `missing`
 * random markers and places `spurious` blobs (discs, elongated ellipses and
 * two-disc clusters, 8-40 mm, in front of the plate, not touching a marker's
 * image). Returns 0, or -1 if no pose keeps all markers in view at this range
 * (after 1000 draws) or a spurious blob found no free place (after 500 draws).
 */
int camera_random_scene(const struct camera_intrinsics *k, const struct camera_scenario *sc,
                        struct camera_rng *rng, struct camera_scene *scene);

/* Per-frame score of a pose_result against the truth. */
struct camera_eval {
    bool valid;         /* status OK or DEGRADED */
    bool correct;       /* valid and no wrong match */
    bool complete;      /* correct and every detected visible marker matched */
    int visible;        /* markers visible in the frame */
    int detected;       /* blobs identified as a visible marker */
    int wrong;          /* matches pairing a blob with the wrong marker (or a spurious blob) */
    int matched_ok;     /* correct matches */
    double rot_err_deg; /* valid frames only */
    double pos_err_mm;
    double extract_sq; /* sum of squared blob-centroid errors vs the ellipse centre, px^2 */
    double raw_sq;     /* ... vs the image of the marker centre */
    double final_sq;   /* sum of squared corrected-centroid errors of correct matches */
    int n_extract;     /* terms in extract_sq and raw_sq */
    int n_final;       /* terms in final_sq */
    int blob_marker[POSE_MAX_OBS]; /* identity of each blob: marker index or -1 */
};

void camera_evaluate(const struct camera_scene *scene, const struct camera_truth *truth,
                     const struct pose_result *res, struct camera_eval *ev);

#endif /* CAMERA_CAMERA_H */
