/* bench_estimator --steps (bench_steps.c): the step-detection delay table. */
#ifndef BENCH_STEPS_H
#define BENCH_STEPS_H

#include <stdint.h>

/* Prints the table of rows from an instantaneous step to the first answer within 3 sd
 * of the new attitude or not ok, per estimator and window mode, averaged over `seeds`
 * runs from first_seed; returns 0. */
int bench_steps(unsigned seeds, uint64_t first_seed);

#endif /* BENCH_STEPS_H */
