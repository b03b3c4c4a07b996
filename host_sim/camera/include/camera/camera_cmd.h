/*
 * `host_sim camera ...`: render K synthetic ToF frames of the paper's target at
 * random poses, run the pose pipeline on each and report its accuracy as JSON.
 *
 *   camera --frames K --range-mm R --spurious S --missing M --depth-noise F
 *          --gray-noise G --seed X --report FILE.json [--image FRAME.png]
 *          [--allow-partial] [--supersample N]
 */
#ifndef CAMERA_CAMERA_CMD_H
#define CAMERA_CAMERA_CMD_H

/*
 * argv[0] is "camera". Returns the process exit status: 0 on success, 2 for a
 * usage error (message on stderr naming the option), 1 for an I/O failure.
 */
int host_sim_camera_main(int argc, char **argv);

#endif /* CAMERA_CAMERA_CMD_H */
