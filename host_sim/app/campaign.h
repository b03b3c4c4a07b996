/*
 * host_sim campaign: the fault-injection campaign of the reliability work.
 * Replays a trace with ground truth under every fault kind of the simulated bus,
 * alone and mixed, at rates from 0.01 % to 5 % per transaction; injection stops
 * at 3/4 of the trace so the return to four healthy sensors is timed.
 *
 *   host_sim campaign [--trace T.csv] [--seed S] [--markdown FILE.md]
 *
 * Without --trace it writes and uses the table1 scenario. Exit status 1 when any
 * run hangs (a main-loop iteration over its budget, or a stall) or reports an
 * unflagged wrong estimate (ok, yet more than 5x its window's bound off).
 */
#ifndef HOST_SIM_CAMPAIGN_H
#define HOST_SIM_CAMPAIGN_H

/* argv[0] is "campaign". Returns the process exit status. */
int campaign_main(int argc, char **argv);

#endif /* HOST_SIM_CAMPAIGN_H */
