/* Functions shared between the pose module's source files (not public API). */
#ifndef POSE_POSE_INTERNAL_H
#define POSE_POSE_INTERNAL_H

#include <stdint.h>

#include "pose/pose.h"

/* Fills the workspace's nLoG kernel for sigma_px (radius ceil(3 sigma), at most the maximum). */
void pose_nlog_kernel(struct pose_workspace *ws, float sigma_px);

/*
 * Extraction proper: out->blobs and counters; *n_components receives how many
 * components were examined. A run overflow sets out->status and returns POSE_OK.
 */
int pose_extract_frame(struct pose_pipeline *p, const struct pose_frame *f, struct pose_result *out,
                       uint16_t *bad_x, uint16_t *bad_y, uint8_t *n_components);

#endif /* POSE_POSE_INTERNAL_H */
