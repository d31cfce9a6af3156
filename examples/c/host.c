/*
 * A flight-software host of the taiji estimator, in plain C99, in the style of a cFS
 * app: initialise from a table, then one processing cycle per sensor sample (update),
 * and the Gauss-Newton solve in the slower rate group whenever update says 60 s of
 * data are in. The estimator's state lives in this program's static memory; the
 * library allocates nothing and returns a status code from every call.
 *
 * Input: an export folder written by `taiji-calib export --telemetry F --out DIR`
 * (estimator_config.bin, sensor_samples.bin). Output on stdout: the final estimates as
 * JSON shaped like report.json's `inertial_sensors`, plus the flight figures measured
 * here (per-call time, state size, stack depth). Build and run: tools/c-host.
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "taiji_estimator.h"

/* The state's memory: static, sized for the state with margin (checked at start). */
#define STATE_WORDS (96u * 1024u / 8u)
static uint64_t state_mem[STATE_WORDS];
#define CKPT_BYTES (96u * 1024u)
static uint8_t ckpt_buf[CKPT_BYTES];
/* The solve's scratch (the Jacobian, the normal equations): static too, any contents. */
#define WORK_WORDS (160u * 1024u / 8u)
static uint64_t work_mem[WORK_WORDS];

/* Stack painting: a region below the caller's frame is filled with a pattern before a
 * call; afterwards, the lowest byte that changed tells how deep the call went. */
#define PAINT_BYTES (256u * 1024u)
#define PAINT 0xA5u

static uintptr_t paint_low;
static uintptr_t paint_top;

static void __attribute__((noinline)) paint_stack(void) {
    volatile uint8_t region[PAINT_BYTES];
    size_t i;
    for (i = 0; i < PAINT_BYTES; i++) region[i] = PAINT;
    paint_low = (uintptr_t)region;
    paint_top = (uintptr_t)&region[PAINT_BYTES - 1];
}

/* Called from the same frame as paint_stack, after the measured call: the region is
 * free stack again; the lowest byte that lost the pattern is the call's deepest. */
static size_t __attribute__((noinline)) painted_depth(void) {
    const volatile uint8_t *low = (const volatile uint8_t *)paint_low;
    size_t i;
    for (i = 0; i < PAINT_BYTES; i++) {
        if (low[i] != PAINT) break;
    }
    return (size_t)(paint_top - (paint_low + i)) + 1;
}

static double now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Reads an export file: header (magic, layout version, record size, count), then the
 * records into a malloc'd buffer (the host's input, not the estimator's memory). */
static void *read_export(const char *dir, const char *name, uint32_t record, uint64_t *count) {
    char path[4096];
    unsigned char h[24];
    uint32_t version, size;
    FILE *f;
    void *data;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "c-host: cannot open %s\n", path);
        exit(2);
    }
    if (fread(h, 1, 24, f) != 24 || memcmp(h, "TJEXP001", 8) != 0) {
        fprintf(stderr, "c-host: %s is not a taiji export\n", path);
        exit(2);
    }
    memcpy(&version, h + 8, 4);
    memcpy(&size, h + 12, 4);
    memcpy(count, h + 16, 8);
    if (version != taiji_layout_version() || size != record) {
        fprintf(stderr,
                "c-host: %s has layout version %u, record %u B; this library has version %u, record %u B\n",
                path, version, size, taiji_layout_version(), record);
        exit(2);
    }
    data = malloc((size_t)(*count ? *count : 1) * record);
    if (!data || fread(data, record, (size_t)*count, f) != (size_t)*count) {
        fprintf(stderr, "c-host: %s is truncated\n", path);
        exit(2);
    }
    fclose(f);
    return data;
}

static void print_vec(const char *key, const double v[3], int last) {
    printf("      \"%s\": [%.17g, %.17g, %.17g]%s\n", key, v[0], v[1], v[2], last ? "" : ",");
}

static void print_param(const char *name, const double est[3], const double sig[3], int last) {
    printf("    \"%s\": {\n", name);
    print_vec("estimate", est, 0);
    print_vec("sigma", sig, 1);
    printf("    }%s\n", last ? "" : ",");
}

#define CHECK(call)                                                                  \
    do {                                                                             \
        int32_t rc_ = (call);                                                        \
        if (rc_ != TAIJI_OK) {                                                       \
            fprintf(stderr, "c-host: %s failed with code %d\n", #call, (int)rc_);   \
            exit(3);                                                                 \
        }                                                                            \
    } while (0)

int main(int argc, char **argv) {
    const char *dir = argc > 1 ? argv[1] : "out/export";
    uint64_t n_cfg = 0, n = 0, i, n_solves = 0;
    struct TaijiEstimatorConfig *cfg;
    struct TaijiSensorSample *samples;
    struct TaijiEstimateMsg est;
    uint8_t *mem = (uint8_t *)state_mem;
    double *t_update, t_solve_max = 0.0, t_max = 0.0;
    uint64_t max_at = 0;
    size_t stack_update = 0, stack_solve = 0, d, written = 0;
    size_t stack_init, stack_ckpt, stack_restore, stack_finish;
    /* After a gap in the ticks the updates bridge it, 8 ticks a call (one of them the
     * sample's own): each is measured. */
    size_t stack_gap = 0;
    uint64_t gap_max = 0, catch_up = 0;
    int is;

    if (taiji_estimator_size() > sizeof state_mem || taiji_estimator_align() > 8 ||
        taiji_solve_work_size() > sizeof work_mem) {
        fprintf(stderr,
                "c-host: the state needs %zu B aligned to %zu and the solve %zu B of scratch; "
                "this host has %zu B and %zu B\n",
                taiji_estimator_size(), taiji_estimator_align(), taiji_solve_work_size(),
                sizeof state_mem, sizeof work_mem);
        return 2;
    }
    cfg = read_export(dir, "estimator_config.bin", sizeof *cfg, &n_cfg);
    samples = read_export(dir, "sensor_samples.bin", sizeof *samples, &n);
    if (n_cfg != 1) {
        fprintf(stderr, "c-host: estimator_config.bin holds %" PRIu64 " tables, not 1\n", n_cfg);
        return 2;
    }
    t_update = malloc((size_t)(n ? n : 1) * sizeof *t_update);
    if (!t_update) return 2;

    paint_stack();
    CHECK(taiji_estimator_init(mem, sizeof state_mem, cfg, TAIJI_ABI_ARGS));
    stack_init = painted_depth();
    for (i = 0; i < n; i++) {
        uint64_t rejected = 0;
        uint32_t flags = 0;
        double t0;
        int measure;
        if (i > 0 && samples[i].header.tick > samples[i - 1].header.tick + 1) {
            uint64_t gap = samples[i].header.tick - samples[i - 1].header.tick - 1;
            if (gap > gap_max) gap_max = gap;
            catch_up = gap / 7 + 2;
        }
        measure = (i % 1000) == 0 || catch_up > 0;
        if (measure) paint_stack();
        t0 = now_us();
        CHECK(taiji_estimator_update(mem, &samples[i], &rejected, &flags));
        t_update[i] = now_us() - t0;
        if (t_update[i] > t_max) {
            t_max = t_update[i];
            max_at = i;
        }
        if (measure) {
            d = painted_depth();
            if (d > stack_update) stack_update = d;
            if (catch_up > 0) {
                if (d > stack_gap) stack_gap = d;
                catch_up--;
            }
        }
        if (flags & TAIJI_SOLVE_DUE) {
            int32_t rc;
            paint_stack();
            t0 = now_us();
            rc = taiji_estimator_solve(mem, (uint8_t *)work_mem, sizeof work_mem);
            t0 = now_us() - t0;
            if ((d = painted_depth()) > stack_solve) stack_solve = d;
            if (t0 > t_solve_max) t_solve_max = t0;
            /* A failed solve keeps the previous solution; the status word says so. */
            if (rc != TAIJI_OK && rc != TAIJI_ERR_SOLVE) CHECK(rc);
            n_solves++;
        }
    }
    /* A checkpoint round trip: the final estimate comes from the restored state. */
    paint_stack();
    CHECK(taiji_estimator_checkpoint(mem, ckpt_buf, sizeof ckpt_buf, &written));
    stack_ckpt = painted_depth();
    memset(state_mem, 0, sizeof state_mem);
    paint_stack();
    CHECK(taiji_estimator_restore(mem, sizeof state_mem, ckpt_buf, written, cfg));
    stack_restore = painted_depth();
    paint_stack();
    CHECK(taiji_estimator_finish(mem, (uint8_t *)work_mem, sizeof work_mem, &est));
    stack_finish = painted_depth();

    printf("{\n  \"inertial_sensors\": [\n");
    for (is = 0; is < (int)cfg->n_is; is++) {
        printf("   {\n    \"id\": %d,\n", is + 1);
        print_param("beta", est.beta[is], est.beta_sigma[is], 0);
        print_param("k", est.k[is], est.k_sigma[is], 0);
        print_param("com_offset", est.r_b[is], est.r_sigma[is], 1);
        printf("   }%s\n", is + 1 < (int)cfg->n_is ? "," : "");
    }
    printf("  ],\n  \"estimator_status\": %" PRIu64 ",\n", est.status);
    printf("  \"samples_used\": %" PRIu64 ",\n  \"samples_rejected\": %" PRIu64 ",\n", est.n_used,
           est.n_rejected);
    qsort(t_update, (size_t)n, sizeof *t_update, cmp_double);
    printf("  \"flight\": {\n");
    printf("    \"updates\": %" PRIu64 ",\n    \"solves\": %" PRIu64 ",\n", n, n_solves);
    if (n > 0) {
        printf("    \"update_us\": {\"p50\": %.3f, \"p99\": %.3f, \"max\": %.3f},\n",
               t_update[n / 2], t_update[(size_t)((double)n * 0.99)], t_update[n - 1]);
    }
    printf("    \"update_max_at\": %" PRIu64 ",\n", max_at);
    printf("    \"solve_us_max\": %.1f,\n", t_solve_max);
    printf("    \"state_bytes\": %zu,\n    \"checkpoint_bytes\": %zu,\n", taiji_estimator_size(),
           written);
    printf("    \"solve_work_bytes\": %zu,\n", taiji_solve_work_size());
    printf("    \"gap_ticks_max\": %" PRIu64 ",\n", gap_max);
    printf("    \"stack_bytes\": {\"init\": %zu, \"update\": %zu, \"update_after_gap\": %zu, "
           "\"solve\": %zu, \"checkpoint\": %zu, \"restore\": %zu, \"finish\": %zu}\n  }\n}\n",
           stack_init, stack_update, stack_gap, stack_solve, stack_ckpt, stack_restore,
           stack_finish);
    free(t_update);
    free(samples);
    free(cfg);
    return 0;
}
