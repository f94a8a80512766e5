/* Drives libhoverbench_online.a from C: the motor map and the estimator initialised from a blob
 * file (with a fourth argument "opt-ins": hb_online_init_with, 1 s windows and the thrust-limit
 * end), a plan, then every sample of a text file ("time_s voltage_v current_a|nan phase" and
 * the four motors' ESC commands in us, or "nan nan nan nan" when not logged, per line), the
 * rotors' power computed from the commands through the motor map, with a capacity reading of
 * 0.9 (one-sigma 0.04) fused after the first; prints the map's power at fixed commands, the
 * estimate every 50 samples and the count of samples the map gave a power for, for the Rust
 * test to compare. The second blob file has no motor map (its error path). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hoverbench_online.h"

static size_t read_blob(const char *path, uint8_t *blob, size_t size) {
    size_t len;
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    len = fread(blob, 1, size, f);
    fclose(f);
    return len;
}

/* The motor map's misuse and out-of-range commands are error codes, the power untouched; then
 * its power at fixed commands, printed. Returns 0, or the failing check's exit code. */
static int check_motor_map(const hb_motor_map *map, const uint8_t *no_motor_blob,
                           size_t no_motor_len) {
    hb_motor_map other;
    const double hover_us[4] = {1480.0, 1510.0, 1495.5, 1502.25};
    double sixteen_us[16], bad_us[4], w4 = -1.0, w16 = -1.0, w = -1.0;
    int k;

    for (k = 0; k < 16; ++k) sixteen_us[k] = 1500.0;
    memset(&other, 0, sizeof other);
    if (hb_motor_power_w(&other, hover_us, 4, 11.8, &w) != HB_ERR_NOT_INITIALISED) return 10;
    if (hb_motor_map_init(no_motor_blob, no_motor_len, &other) != HB_ERR_NO_MOTOR_MAP) return 11;
    if (hb_motor_power_w(&other, hover_us, 4, 11.8, &w) != HB_ERR_NOT_INITIALISED) return 11;
    if (hb_motor_map_init(no_motor_blob, 3, &other) != HB_ERR_BLOB) return 11;
    if (hb_motor_map_init(NULL, no_motor_len, &other) != HB_ERR_NULL) return 11;
    if (hb_motor_map_init(no_motor_blob, no_motor_len, NULL) != HB_ERR_NULL) return 11;
    if (hb_motor_power_w(NULL, hover_us, 4, 11.8, &w) != HB_ERR_NULL) return 12;
    if (hb_motor_power_w(map, NULL, 4, 11.8, &w) != HB_ERR_NULL) return 12;
    if (hb_motor_power_w(map, hover_us, 4, 11.8, NULL) != HB_ERR_NULL) return 12;
    if (hb_motor_power_w(map, hover_us, 0, 11.8, &w) != HB_ERR_OPTION) return 13;
    if (hb_motor_power_w(map, sixteen_us, HB_MOTOR_MAP_MAX_MOTORS + 1u, 11.8, &w) != HB_ERR_OPTION)
        return 13;
    /* Idle on the ground: the motors turn slower than the sweeps' first step. */
    memcpy(bad_us, hover_us, sizeof bad_us);
    bad_us[2] = 1060.0;
    if (hb_motor_power_w(map, bad_us, 4, 11.8, &w) != HB_ERR_DRIVE_BELOW_RANGE) return 14;
    /* Full throttle on a full 3S pack: 12.6 V of drive, past the sweeps' 12 V. */
    bad_us[2] = 2000.0;
    if (hb_motor_power_w(map, bad_us, 4, 12.6, &w) != HB_ERR_DRIVE_ABOVE_RANGE) return 15;
    /* The first failing rotor gives the code. */
    bad_us[0] = 1000.0;
    if (hb_motor_power_w(map, bad_us, 4, 12.6, &w) != HB_ERR_DRIVE_BELOW_RANGE) return 14;
    bad_us[0] = NAN;
    if (hb_motor_power_w(map, bad_us, 4, 11.8, &w) != HB_ERR_INPUT) return 16;
    if (hb_motor_power_w(map, hover_us, 4, 0.0, &w) != HB_ERR_INPUT) return 16;
    if (hb_motor_power_w(map, hover_us, 4, NAN, &w) != HB_ERR_INPUT) return 16;
    if (w != -1.0) return 17;
    if (hb_motor_power_w(map, hover_us, 4, 11.8, &w4) != HB_OK) return 18;
    if (hb_motor_power_w(map, sixteen_us, HB_MOTOR_MAP_MAX_MOTORS, 11.8, &w16) != HB_OK) return 18;
    printf("motor %.17g %.17g\n", w4, w16);
    return 0;
}

int main(int argc, char **argv) {
    static uint8_t blob[4096], no_motor_blob[4096];
    hb_online_state state;
    hb_online_estimate e;
    hb_motor_map map;
    FILE *f;
    size_t len, no_motor_len;
    long n = 0, motor_ok = 0;
    double t, v, i, w, us[4];
    int phase, rc, observed = 0;
    hb_plan_segment plan[2];

    if (argc != 4 && !(argc == 5 && strcmp(argv[4], "opt-ins") == 0)) {
        fprintf(stderr, "usage: %s BLOB BLOB_WITHOUT_MOTOR_MAP SAMPLES [opt-ins]\n", argv[0]);
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

    len = read_blob(argv[1], blob, sizeof blob);
    no_motor_len = read_blob(argv[2], no_motor_blob, sizeof no_motor_blob);
    if (len == 0 || no_motor_len == 0) return 4;
    if (hb_motor_map_init(blob, len, &map) != HB_OK) return 9;
    rc = check_motor_map(&map, no_motor_blob, no_motor_len);
    if (rc != 0) return rc;
    if (hb_online_init_with(blob, len, NAN, 0, &state) != HB_ERR_OPTION) return 3;
    if (hb_online_init_with(blob, len, -1.0, 0, &state) != HB_ERR_OPTION) return 3;
    if (hb_online_read(&state, &e) != HB_ERR_NOT_INITIALISED) return 3;
    rc = argc == 5 ? hb_online_init_with(blob, len, 1.0, 1, &state)
                   : hb_online_init(blob, len, &state);
    if (rc != HB_OK) {
        printf("init %d\n", (int)rc);
        return 1;
    }
    if (hb_online_zero_current(NULL, 1) != HB_ERR_NULL) return 8;
    if (hb_online_extra_resistance_sigma(NULL, 0.02) != HB_ERR_NULL) return 8;
    if (hb_online_extra_resistance_sigma(&state, -1.0) != HB_ERR_OPTION) return 8;
    if (hb_online_extra_resistance_sigma(&state, NAN) != HB_ERR_OPTION) return 8;
    if (hb_online_resync_resistance_sigma(NULL, 0.1) != HB_ERR_NULL) return 8;
    if (hb_online_resync_resistance_sigma(&state, -1.0) != HB_ERR_OPTION) return 8;
    if (hb_online_resync_resistance_sigma(&state, INFINITY) != HB_ERR_OPTION) return 8;
    /* The default, set again: the same estimates as the Rust replay's. */
    if (hb_online_resync_resistance_sigma(&state, 0.1) != HB_OK) return 8;
    /* With the opt-ins, the current sensor's zero is read on the ground before take-off. */
    if (argc == 5 && hb_online_zero_current(&state, 1) != HB_OK) return 8;
    plan[0].kind = HB_SEGMENT_HOVER_MIN;
    plan[0].value = 3.0;
    plan[1].kind = HB_SEGMENT_HOVER_UNTIL_EMPTY;
    plan[1].value = 0.0;
    if (hb_online_set_plan(&state, plan, 2, 0.0) != HB_OK) return 5;
    /* No sample yet: nothing to fuse a reading into. */
    if (hb_online_observe(&state, HB_STATE_CAPACITY_SCALE, 0.9, 0.04) != HB_ERR_OBSERVE) return 7;

    f = fopen(argv[3], "r");
    if (!f) return 4;
    while (fscanf(f, "%lf %lf %lf %d %lf %lf %lf %lf", &t, &v, &i, &phase, &us[0], &us[1], &us[2],
                  &us[3]) == 8) {
        if (isnan(us[0])) {
            rc = hb_online_update(&state, t, v, i, (uint8_t)phase);
        } else {
            /* The rotors' power from the motor commands at the pack's voltage; NAN when the
             * map cannot give it (a voltage that is not a number, a drive outside its range). */
            if (hb_motor_power_w(&map, us, 4, v, &w) == HB_OK) {
                ++motor_ok;
            } else {
                w = NAN;
            }
            rc = hb_online_update_motors(&state, t, v, i, (uint8_t)phase, w);
        }
        if (rc < 0) {
            printf("update %d\n", (int)rc);
            return 1;
        }
        if (!observed) {
            /* Too late to switch the zero read once a sample is taken. */
            if (hb_online_zero_current(&state, 0) != HB_ERR_OPTION) return 8;
            if (hb_online_extra_resistance_sigma(&state, 0.02) != HB_ERR_OPTION) return 8;
            if (hb_online_resync_resistance_sigma(&state, 0.0) != HB_ERR_OPTION) return 8;
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
    printf("motor_ok %ld\n", motor_ok);
    printf("size %lu %lu %lu %lu %lu\n", (unsigned long)sizeof(hb_online_state),
           (unsigned long)sizeof(hb_online_estimate), (unsigned long)hb_online_state_size(),
           (unsigned long)sizeof(hb_motor_map), (unsigned long)hb_motor_map_size());
    return 0;
}
