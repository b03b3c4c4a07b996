/* tof_twin's outputs after the run: the executed flash ranges (coverage), the one-line
 * summary and the report JSON (docs/reference/tools.md keeps its keys). */
#include <errno.h>
#include <inttypes.h>
#include <string.h>

#include "tof_twin.h"

int tof_twin_write_coverage(const struct run *r) {
    FILE *f = fopen(r->a.coverage, "w");
    if (f == NULL) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.coverage, strerror(errno));
        return -1;
    }
    fputs("# executed flash ranges [start, end) from the twin's block hook\n", f);
    const uint32_t n = TWIN_FLASH_SIZE / 2u;
    for (uint32_t i = 0; i < n;) {
        if (!r->t.covered[i]) {
            ++i;
            continue;
        }
        uint32_t j = i;
        while (j < n && r->t.covered[j]) {
            ++j;
        }
        fprintf(f, "0x%08x 0x%08x\n", TWIN_FLASH_BASE + 2u * i, TWIN_FLASH_BASE + 2u * j);
        i = j;
    }
    return fclose(f);
}

void tof_twin_print_summary(const struct run *r, bool finished, double host_s) {
    const double minsn = (double)r->t.stats.instructions / 1e6;
    fprintf(stderr,
            "tof_twin: %s: %.3f s simulated, %.2f s host, %.1f M instructions (%.1f M/s), "
            "%" PRIu64 " estimates (%" PRIu64 " rows written), %u boots, %u watchdog resets, "
            "%u HardFaults, %" PRIu64 " unflagged wrong\n",
            finished ? "done" : "FAILED", (double)twin_now_ps(&r->t) / 1e12, host_s, minsn,
            host_s > 0 ? minsn / host_s : 0.0, r->estimates, r->written, r->boots,
            r->t.stats.watchdog_resets, r->t.stats.hardfaults, r->unflagged_wrong);
    const struct tof_twin_pty *p = &r->pty;
    if (r->a.pty) {
        fprintf(stderr,
                "tof_twin: pty %s: %u opens, %u commands, %u answered (%u nacks), ack latency "
                "max %.3f ms simulated, %" PRIu64 " bytes in, %" PRIu64 " out, %" PRIu64
                " dropped, %.2f s slept\n",
                p->path, p->opens, p->commands, p->answered, p->nacked,
                (double)p->ack_latency_max_ps / 1e9, p->bytes_in, p->bytes_out, p->dropped,
                (double)p->slept_ns / 1e9);
    }
}

int tof_twin_write_report(const struct run *r, bool finished, double host_s) {
    const double minsn = (double)r->t.stats.instructions / 1e6;
    FILE *f = fopen(r->a.report, "w");
    if (f == NULL) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.report, strerror(errno));
        return -1;
    }
    fprintf(f,
            "{\"finished\": %s, \"stop\": \"%s\", \"sim_s\": %.6f, \"host_s\": %.3f,\n"
            " \"instructions\": %" PRIu64 ", \"minsn_per_s\": %.2f, \"warps\": %" PRIu64 ",\n"
            " \"mmio_reads\": %" PRIu64 ", \"mmio_writes\": %" PRIu64 ",\n"
            " \"estimates\": %" PRIu64 ", \"rows_written\": %" PRIu64 ", \"ok_rows\": %" PRIu64
            ", \"unflagged_wrong\": %" PRIu64 ",\n"
            " \"boots\": %u, \"banners\": %" PRIu64 ", \"resets\": %u, \"watchdog_resets\": %u,"
            " \"software_resets\": %u, \"hardfaults\": %u, \"fault_pc\": %u, \"fault_addr\": %u,\n"
            " \"fault_lines\": %" PRIu64 ", \"last_fault\": \"%s\", \"systicks\": %u,\n"
            " \"i2c_transfers\": %" PRIu64 ", \"spurious_berr\": %u, \"bus_recoveries\": %u,"
            " \"commands_refused\": %u,\n"
            " \"health_frames\": %" PRIu64 ", \"loop_overruns\": %u, \"loop_max_us\": %u,"
            " \"tx_dropped\": %u, \"uart_overruns\": %" PRIu64 ", \"fw_uart_overruns\": %u,\n"
            " \"commands_sent\": %u, \"commands_acked\": %u, \"commands_out_of_order\": %u,"
            " \"commands_unmatched\": %u, \"ack_latency_max_us\": %" PRIu64 ",\n"
            " \"status_confirmed\": %u, \"rows_missing\": %" PRIu64 ", \"irqs\": %" PRIu64 ",\n"
            " \"record_state\": %u, \"calibration_state\": %u, \"boot_window\": %u,"
            " \"boot_sliding\": %u,"
            " \"flash_erases\": %u, \"flash_programs\": %u, \"flash_cuts\": %u,\n"
            " \"pty\": %s, \"pty_opens\": %u, \"pty_commands\": %u, \"pty_answered\": %u,"
            " \"pty_nacked\": %u, \"pty_ack_latency_max_us\": %" PRIu64 ","
            " \"pty_ack_latency_mean_us\": %" PRIu64 ",\n"
            " \"pty_bytes_in\": %" PRIu64 ", \"pty_bytes_out\": %" PRIu64 ","
            " \"pty_dropped\": %" PRIu64 ", \"pty_unheard\": %" PRIu64 ", \"pty_slept_s\": %.3f,"
            " \"pty_behind_max_ms\": %.3f,\n",
            finished ? "true" : "false", finished ? "" : r->t.stop_msg,
            (double)twin_now_ps(&r->t) / 1e12, host_s, r->t.stats.instructions,
            host_s > 0 ? minsn / host_s : 0.0, r->t.stats.warps, r->t.stats.mmio_reads,
            r->t.stats.mmio_writes, r->estimates, r->written, r->ok_rows, r->unflagged_wrong,
            r->boots, r->banners, r->t.stats.resets, r->t.stats.watchdog_resets,
            r->t.stats.software_resets, r->t.stats.hardfaults, r->t.fault_pc, r->t.fault_addr,
            r->faults_text, r->last_fault, r->t.stats.exceptions[15], r->w.transfers,
            r->t.i2c.berr_injected, r->w.rig.bus.stats.recoveries, r->acks_bad, r->health_frames,
            r->health.loop_overruns, r->health.loop_max_us, r->health.tx_dropped,
            r->t.usart.overruns, r->health.uart_overruns, r->commands_sent, r->commands_acked,
            r->commands_out_of_order, r->commands_unmatched, r->ack_latency_max_ps / 1000000u,
            r->status_confirmed, r->rows_missing, r->t.stats.irqs, r->boot_status.record,
            r->boot_status.calibration, r->boot_status.window_n,
            r->boot_status.mode == TLM_WINDOW_SLIDING ? 1u : 0u, r->t.flash_pe.erases,
            r->t.flash_pe.programs, r->t.flash_pe.cuts, r->a.pty ? "true" : "false", r->pty.opens,
            r->pty.commands, r->pty.answered, r->pty.nacked, r->pty.ack_latency_max_ps / 1000000u,
            r->pty.answered > 0u ? r->pty.ack_latency_sum_ps / r->pty.answered / 1000000u : 0u,
            r->pty.bytes_in, r->pty.bytes_out, r->pty.dropped, r->pty.unheard,
            (double)r->pty.slept_ns / 1e9, (double)r->pty.behind_max_ns / 1e6);
    /* The ADC's temperature path (twin_adc.c) and ST's temperature updates the parts saw. */
    const struct twin_adc *adc = &r->t.adc;
    fprintf(
        f,
        " \"adc_conversions\": %u, \"adc_sensor_conversions\": %u,"
        " \"adc_temp_unknown\": %u, \"adc_first_temp_c\": %.2f, \"adc_last_temp_c\": %.2f,"
        " \"part_temp_updates\": [%u, %u, %u, %u]}\n",
        adc->conversions, adc->sensor_conversions, adc->unknown_temperature,
        adc->first_cdeg / 100.0, adc->last_cdeg / 100.0,
        r->w.rig.sensor[0].stats.temperature_updates, r->w.rig.sensor[1].stats.temperature_updates,
        r->w.rig.sensor[2].stats.temperature_updates, r->w.rig.sensor[3].stats.temperature_updates);
    fclose(f);
    return 0;
}
