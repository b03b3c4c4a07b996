/* The replay's distance mode from a trace v1 (trace/trace_v1.h): one policy for every target. */
#include "trace/trace_v1.h"

#include <stddef.h>

void trace_mode_evidence_add(struct trace_mode_evidence *ev, const struct trace_v1_row *row,
                             uint32_t line) {
    for (unsigned k = 0; k < 4u; ++k) {
        const uint16_t mm = row->range_mm[k];
        if (row->present[k] && mm > ev->short_max_mm && mm <= ev->long_max_mm) {
            if (ev->count++ == 0u) {
                ev->first_line = line;
                ev->first_sensor = (uint8_t)k;
            }
        }
    }
}

struct trace_mode_choice trace_mode_choose(enum trace_mode option, enum trace_mode stated,
                                           const struct trace_mode_evidence *ev, bool long_fits) {
    if (option != TRACE_MODE_UNSTATED) {
        return (struct trace_mode_choice){option, TRACE_MODE_BY_OPTION};
    }
    if (stated != TRACE_MODE_UNSTATED) {
        return (struct trace_mode_choice){stated, TRACE_MODE_BY_TRACE};
    }
    if (ev == NULL) {
        return (struct trace_mode_choice){TRACE_MODE_SHORT, TRACE_MODE_NOT_READ_AHEAD};
    }
    if (ev->count == 0u) {
        return (struct trace_mode_choice){TRACE_MODE_SHORT, TRACE_MODE_NO_EVIDENCE};
    }
    return long_fits ? (struct trace_mode_choice){TRACE_MODE_LONG, TRACE_MODE_BY_READINGS}
                     : (struct trace_mode_choice){TRACE_MODE_SHORT, TRACE_MODE_NO_BUDGET};
}
