/*
 * host_sim_camera: stand-alone front end of `host_sim camera` until the
 * integrator wires host_sim_camera_main() into the host_sim executable.
 */
#include "camera/camera_cmd.h"

int main(int argc, char **argv) {
    return host_sim_camera_main(argc, argv);
}
