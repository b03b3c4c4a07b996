/* The paper's cooperative target (§2.1, Fig. 1c): a black plate with eight
 * circular reflectors in two L-shaped groups of four. Markers 1-4 are 35 mm
 * across, 5-8 are 80 mm; markers 1, 3, 4, 7 stand 100 mm above the plate and
 * 2, 5, 6, 8 stand 150 mm. The paper gives no positions in the plate plane, so
 * this layout is ours (docs/explanation/pose.md draws it):
 *   - small L (1-4): corner 1 at lower left, long arm along +x through 2 and 3
 *     (105 and 100 mm steps), short arm along +y to 4 (70 mm);
 *   - large L (5-8): corner 5 at upper right, long arm along -x through 6 and 7
 *     (120 and 165 mm steps), short arm along -y to 8 (105 mm).
 * Constraints it satisfies (found by a small search):
 *   - markers of different heights are >= 62 mm apart edge to edge, so the
 *     parallax of their 50 mm height difference (up to 46 deg off the plate
 *     normal: 20 deg tilt plus 26 deg off axis) never makes their images touch;
 *   - all 28 pairwise 3-D distances are distinct (closest two differ by 2.4 mm),
 *     so no relabelling preserves them and matching by distances is unambiguous;
 *   - it fits a 440 x 300 mm plate centred on the target origin.
 * Array index k is the paper's marker k+1.
 */
#include "pose/pose.h"

const struct pose_marker pose_paper_target[8] = {
    {{-170.0f, -105.0f, 100.0f}, 35.0f}, /* 1: small L corner */
    {{-65.0f, -105.0f, 150.0f}, 35.0f},  /* 2 */
    {{35.0f, -105.0f, 100.0f}, 35.0f},   /* 3 */
    {{-170.0f, -35.0f, 100.0f}, 35.0f},  /* 4 */
    {{150.0f, 85.0f, 150.0f}, 80.0f},    /* 5: large L corner */
    {{30.0f, 85.0f, 150.0f}, 80.0f},     /* 6 */
    {{-135.0f, 85.0f, 100.0f}, 80.0f},   /* 7 */
    {{150.0f, -20.0f, 150.0f}, 80.0f},   /* 8 */
};
