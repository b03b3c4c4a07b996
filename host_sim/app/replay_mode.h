/*
 * host_sim replay's distance mode for the simulated parts: the policy is sim/'s
 * (trace_mode_choose, shared with the QEMU image); this part reads the trace ahead for
 * its evidence, checks the trace's distance_mode and says what was chosen and why.
 */
#ifndef HOST_SIM_REPLAY_MODE_H
#define HOST_SIM_REPLAY_MODE_H

#include <stdint.h>

#include "scene/trace.h"
#include "vl53/vl53.h"

struct replay_mode {
    enum vl53_distance_mode mode;
    char source[200]; /* why that mode, for the summary and the report */
};

/*
 * The mode for the trace at path (reader: opened on it, its metadata read): option
 * (--distance-mode, 0 none), else the trace's distance_mode (checked either way), else
 * long when the trace holds readings only long mode reports and period_ms admits a
 * long-mode budget, else short. Said on stderr when chosen from the readings, or when
 * they could not be read ahead. 0, or -1 (a bad distance_mode, said on stderr).
 */
int replay_mode_choose(struct replay_mode *m, const struct trace_reader *reader, const char *path,
                       unsigned option, uint32_t period_ms);

#endif /* HOST_SIM_REPLAY_MODE_H */
