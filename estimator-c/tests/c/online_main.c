/* Drives libhoverbench_online.a from C: init from a blob file (with a third argument "opt-ins":
 * hb_online_init_with, 1 s windows and the thrust-limit end), a plan, then every sample of a
 * text file ("time_s voltage_v current_a|nan phase motor_power_w|nan" per line), with a capacity reading of 0.9
 * (one-sigma 0.04) fused after the first; prints the estimate every 50 samples for the Rust
 * test to compare. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hoverbench_online.h"

int main(int argc, char **argv) {
    static uint8_t blob[4096];
    hb_online_state state;
    hb_online_estimate e;
    FILE *f;
    size_t len;
    long n = 0;
    double t, v, i, w;
    int phase, rc, observed = 0;
    hb_plan_segment plan[2];

    if (argc != 3 && !(argc == 4 && strcmp(argv[3], "opt-ins") == 0)) {
        fprintf(stderr, "usage: %s BLOB SAMPLES [opt-ins]\n", argv[0]);
        return 2;
    }
    /* Misuse is an error code, not a crash. */
    memset(&state, 0, sizeof state);
    if (hb_online_read(&state, &e) != HB_ERR_NOT_INITIALISED) return 3;
    if (hb_online_update(NULL, 0.0, 12.0, NAN, HB_PHASE_HOVER) != HB_ERR_NULL) return 3;
    if (hb_online_update_motors(NULL, 0.0, 12.0, NAN, HB_PHASE_HOVER, 50.0) != HB_ERR_NULL)
        return 3;
    if (hb_online_init(blob, 3, &state) != HB_ERR_BLOB) return 3;
    if (hb_online_observe(&state, HB_STATE_CAPACITY_SCALE, 0.9, 0.04) != HB_ERR_NOT_INITIALISED)
        return 3;

    f = fopen(argv[1], "rb");
    if (!f) return 4;
    len = fread(blob, 1, sizeof blob, f);
    fclose(f);
    if (hb_online_init_with(blob, len, NAN, 0, &state) != HB_ERR_OPTION) return 3;
    if (hb_online_init_with(blob, len, -1.0, 0, &state) != HB_ERR_OPTION) return 3;
    if (hb_online_read(&state, &e) != HB_ERR_NOT_INITIALISED) return 3;
    rc = argc == 4 ? hb_online_init_with(blob, len, 1.0, 1, &state)
                   : hb_online_init(blob, len, &state);
    if (rc != HB_OK) {
        printf("init %d\n", (int)rc);
        return 1;
    }
    if (hb_online_zero_current(NULL, 1) != HB_ERR_NULL) return 8;
    /* With the opt-ins, the current sensor's zero is read on the ground before take-off. */
    if (argc == 4 && hb_online_zero_current(&state, 1) != HB_OK) return 8;
    plan[0].kind = HB_SEGMENT_HOVER_MIN;
    plan[0].value = 3.0;
    plan[1].kind = HB_SEGMENT_HOVER_UNTIL_EMPTY;
    plan[1].value = 0.0;
    if (hb_online_set_plan(&state, plan, 2, 0.0) != HB_OK) return 5;
    /* No sample yet: nothing to fuse a reading into. */
    if (hb_online_observe(&state, HB_STATE_CAPACITY_SCALE, 0.9, 0.04) != HB_ERR_OBSERVE) return 7;

    f = fopen(argv[2], "r");
    if (!f) return 4;
    while (fscanf(f, "%lf %lf %lf %d %lf", &t, &v, &i, &phase, &w) == 5) {
        /* The rotors' power from the motor commands, where the log has no current. */
        rc = isnan(w) ? hb_online_update(&state, t, v, i, (uint8_t)phase)
                      : hb_online_update_motors(&state, t, v, i, (uint8_t)phase, w);
        if (rc < 0) {
            printf("update %d\n", (int)rc);
            return 1;
        }
        if (!observed) {
            /* Too late to switch the zero read once a sample is taken. */
            if (hb_online_zero_current(&state, 0) != HB_ERR_OPTION) return 8;
            /* The pack's last flight measured 90 % of the model's capacity (one-sigma 4 %). */
            if (hb_online_observe(&state, 99u, 0.9, 0.04) != HB_ERR_OBSERVE) return 7;
            if (hb_online_observe(&state, HB_STATE_CAPACITY_SCALE, 0.9, 0.0) != HB_ERR_OBSERVE)
                return 7;
            if (hb_online_observe(&state, HB_STATE_CAPACITY_SCALE, 0.9, 0.04) != HB_OK) return 7;
            observed = 1;
        }
        if (++n % 50 == 0) {
            if (hb_online_read(&state, &e) != HB_OK) return 6;
            printf("%ld %.17g %.17g %.17g %.17g %.17g %.17g %.17g %u %u %u\n", n,
                   e.remaining_phase_s, e.remaining_phase_sigma_s, e.remaining_plan_s, e.soc,
                   e.usable_capacity_ah, e.series_resistance_ohm, e.extra_power_w,
                   (unsigned)e.flags, (unsigned)e.samples_used, (unsigned)e.has_plan);
        }
    }
    fclose(f);
    printf("size %lu %lu %lu\n", (unsigned long)sizeof(hb_online_state),
           (unsigned long)sizeof(hb_online_estimate), (unsigned long)hb_online_state_size());
    return 0;
}
