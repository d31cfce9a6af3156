/*
 * The work of the slowest update, without the operating system's share: the whole
 * campaign is run PASSES times from the same table, each update timed every time, and
 * each call keeps its fastest time. A preemption or an interrupt lands on different
 * calls in different passes, so the per-call minimum is the library's own time; its
 * maximum over the calls is the update's worst case. Used by tools/flight-figures.
 *   update_floor EXPORT_DIR [PASSES]
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "taiji_estimator.h"

static uint64_t state_mem[96u * 1024u / 8u];
static uint64_t work_mem[160u * 1024u / 8u];

static double now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static void *load(const char *dir, const char *name, size_t record, uint64_t *count) {
    char path[4096];
    unsigned char h[24];
    void *data;
    FILE *f;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    f = fopen(path, "rb");
    if (!f || fread(h, 1, 24, f) != 24 || memcmp(h, "TJEXP001", 8) != 0) {
        fprintf(stderr, "update_floor: %s is not a taiji export\n", path);
        exit(2);
    }
    memcpy(count, h + 16, 8);
    data = malloc((size_t)(*count ? *count : 1) * record);
    if (!data || fread(data, record, (size_t)*count, f) != (size_t)*count) {
        fprintf(stderr, "update_floor: %s is truncated\n", path);
        exit(2);
    }
    fclose(f);
    return data;
}

int main(int argc, char **argv) {
    const char *dir = argc > 1 ? argv[1] : "out/export";
    int passes = argc > 2 ? atoi(argv[2]) : 5, p;
    uint64_t n_cfg, n, i, worst = 0, over = 0;
    struct TaijiEstimatorConfig *cfg = load(dir, "estimator_config.bin", sizeof *cfg, &n_cfg);
    struct TaijiSensorSample *s = load(dir, "sensor_samples.bin", sizeof *s, &n);
    double *best = malloc((size_t)(n ? n : 1) * sizeof *best);
    if (!best || n == 0 || passes < 1) return 2;
    for (i = 0; i < n; i++) best[i] = 1e30;
    for (p = 0; p < passes; p++) {
        if (taiji_estimator_init((uint8_t *)state_mem, sizeof state_mem, cfg, TAIJI_ABI_ARGS) != TAIJI_OK) return 3;
        for (i = 0; i < n; i++) {
            uint32_t flags = 0;
            double t0 = now_us(), d;
            if (taiji_estimator_update((uint8_t *)state_mem, &s[i], NULL, &flags) != TAIJI_OK) return 3;
            d = now_us() - t0;
            if (d < best[i]) best[i] = d;
            if (flags & TAIJI_SOLVE_DUE) taiji_estimator_solve((uint8_t *)state_mem, (uint8_t *)work_mem, sizeof work_mem);
        }
    }
    for (i = 0; i < n; i++) {
        if (best[i] > best[worst]) worst = i;
        if (best[i] > 5.0) over++;
    }
    printf("{\"passes\": %d, \"update_work_us_max\": %.3f, \"at_call\": %" PRIu64
           ", \"calls_over_5us\": %" PRIu64 "}\n",
           passes, best[worst], worst, over);
    free(best);
    free(s);
    free(cfg);
    return 0;
}
