/* Every function of the C ABI, called once, for tools/panic-proof: linked with
 * --gc-sections against the library built with its proving panic handler, this
 * program keeps exactly the code a flight host can reach. With TAIJI_PANIC_PROBE it
 * also calls the probe, a deliberately reachable panic (the check's negative test). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "taiji_estimator.h"

#ifdef TAIJI_PANIC_PROBE
uint8_t taiji_panic_probe(size_t index);
#endif

int main(int argc, char **argv) {
    (void)argv;
    size_t size = taiji_estimator_size();
    uint8_t *mem = aligned_alloc(taiji_estimator_align(), (size + 63) / 64 * 64);
    uint8_t *ckpt = malloc(taiji_checkpoint_size());
    size_t work_size = taiji_solve_work_size();
    uint8_t *work = aligned_alloc(8, (work_size + 63) / 64 * 64);
    struct TaijiEstimatorConfig cfg;
    struct TaijiSensorSample sample;
    struct TaijiEstimateMsg out;
    uint64_t rejected = 0;
    uint32_t flags = 0;
    size_t written = 0;
    if (!mem || !ckpt || !work) return 1;
    /* Contents the compiler cannot know: every path of the library stays reachable. */
    memset(&cfg, argc, sizeof cfg);
    memset(&sample, argc, sizeof sample);
    int32_t rc = taiji_estimator_init(mem, size, &cfg, TAIJI_ABI_ARGS);
    rc |= taiji_estimator_update(mem, &sample, &rejected, &flags);
    rc |= taiji_estimator_solve(mem, work, work_size);
    rc |= taiji_estimator_estimate(mem, &out);
    rc |= taiji_estimator_checkpoint(mem, ckpt, taiji_checkpoint_size(), &written);
    rc |= taiji_estimator_finish(mem, work, work_size, &out);
    rc |= taiji_estimator_restore(mem, size, ckpt, written, &cfg);
    printf("layout %u, abi %u, upset check %u, rc %d\n", taiji_layout_version(), taiji_abi_version(),
           taiji_upset_check(), rc);
#ifdef TAIJI_PANIC_PROBE
    printf("probe %u\n", taiji_panic_probe((size_t)argc));
#endif
    free(work);
    free(ckpt);
    free(mem);
    return 0;
}
