/*
 * Reflector matching by deterministic annealing (paper §4; Christian et al. 2014,
 * the paper's ref. [3]): assign observed 3-D reflector positions to catalog
 * reflectors using only pairwise distances, which do not depend on the unknown
 * pose, so no initial pose is needed.
 *
 * The paper's mean-field iteration (Eqs. 33-37) with an explicit exponential
 * cooling schedule beta_k = beta0 * rate^k. Two documented departures:
 *  - the paper normalises rows only (Eq. 36), which lets two observations claim
 *    the same catalog reflector; here rows and columns are normalised
 *    alternately (Sinkhorn, bounded) with a slack row and column, as in Gold and
 *    Rangarajan's graduated assignment, so the result is one-to-one and an
 *    observation with too little support goes to the slack (spurious) column;
 *  - the clique potential is a compatibility in [0, 1] (Tukey biweight of the
 *    distance mismatch over a per-pair tolerance built from each point's
 *    standard error), so one spurious point cannot outweigh the consistent rest.
 */
#ifndef POSE_POSE_MATCH_H
#define POSE_POSE_MATCH_H

#include <stddef.h>
#include <stdint.h>

#include "pose/pose_types.h"

#ifdef __cplusplus
extern "C" {
#endif

#define POSE_MAX_OBS_PAIRS      (POSE_MAX_OBS * (POSE_MAX_OBS - 1u) / 2u)
#define POSE_MAX_MARKER_PAIRS   (POSE_MAX_MARKERS * (POSE_MAX_MARKERS - 1u) / 2u)
#define POSE_MATCH_MAX_SINKHORN 64u

struct pose_match_config {
    float tol_mm;                /* distance tolerance floor: model and calibration error */
    float tol_sigmas;            /* plus this many combined standard errors of the two points */
    float beta0;                 /* initial inverse temperature (1 / T0) */
    float beta_rate;             /* cooling: beta_{k+1} = beta_rate * beta_k, > 1 */
    float beta_max;              /* stop when beta exceeds this */
    float slack_support;         /* support (sum of compatibilities) an assignment must beat */
    uint8_t sinkhorn_iterations; /* alternating normalisations per temperature */
    float accept_probability;    /* final assignment needs M_ia >= this */
};

/*
 * One observed reflector: its 3-D position in the camera frame (range along its
 * line of sight, which is point / |point|) and the standard errors of its range
 * and of its position across the line of sight.
 */
struct pose_match_obs {
    float point_mm[3];
    float range_sigma_mm;
    float lateral_sigma_mm;
};

/* Scratch memory of the matcher (no heap): distance tables, compatibilities, M. */
struct pose_match_work {
    uint8_t compat[POSE_MAX_OBS_PAIRS][POSE_MAX_MARKER_PAIRS]; /* 255 = exact agreement */
    float marker_dist[POSE_MAX_MARKER_PAIRS];
    float m[POSE_MAX_OBS + 1u][POSE_MAX_MARKERS + 1u]; /* assignment probabilities + slack */
    float q[POSE_MAX_OBS][POSE_MAX_MARKERS];           /* support of each assignment */
};

/* Defaults used by the pipeline (values and reasons in pose_match.c). */
void pose_match_config_default(struct pose_match_config *cfg);

/* True when every field is in range (cooling rate > 1, bounded Sinkhorn count, ...). */
bool pose_match_config_valid(const struct pose_match_config *cfg);

/*
 * Assigns observations to markers. assignment[i] receives the marker index of
 * observation i or -1 (spurious / unassigned). Returns the number of matches
 * (>= 0) or POSE_ERR_INVALID (bad config, too many points). *iterations (may be
 * NULL) receives the number of temperature steps taken.
 */
int pose_match(const struct pose_match_config *cfg, const struct pose_marker *markers,
               size_t n_markers, const struct pose_match_obs *obs, size_t n_obs,
               struct pose_match_work *work, int8_t *assignment, uint16_t *iterations);

/* Index of the unordered pair (i, j), i != j, among n points: 0 .. n(n-1)/2 - 1. */
size_t pose_pair_index(size_t i, size_t j, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* POSE_POSE_MATCH_H */
