/*
 * libFuzzer target: drivers/vl53 + drivers/vl53_array against a bus whose every
 * answer comes from the input (fuzz_vl53_harness.h: outcomes, durations, bytes
 * read, GPIO levels, the operations and their arguments). Every call must
 * return a hal_err code within the time bound its header states, never crash,
 * and keep its documented invariants.
 *
 * Long run: docs/explanation/reliability.md, "Fuzzing".
 */
#include <stddef.h>
#include <stdint.h>

#include "fuzz_input.h"
#include "fuzz_vl53_harness.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint8_t input_next(void *ctx, enum fz_kind kind, const struct fz_request *req) {
    (void)kind;
    (void)req;
    return fuzz_u8(ctx);
}

static bool input_done(void *ctx) {
    return fuzz_input_done(ctx);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct fuzz_input in = fuzz_input_make(data, size);
    const struct fz_source src = {input_next, input_done, &in};
    fz_vl53_run(&src);
    return 0;
}
