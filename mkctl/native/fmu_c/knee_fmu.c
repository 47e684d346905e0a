/* The knee's part of the native McKibbenKnee FMU: the run of mkctl.physics.simulate.KneeSimulator, in C.
 *
 * Start (as the pythonfmu knee): n left at its start value while b, L0 or D0 change follows them; X0 left at
 * its start value is the hip height at alpha = 60 deg of the geometry; the leg starts at rest, the lag pressures
 * at the commands. The
 * end stops of mkctl.physics.knee engage at the core's mk_stop_positions. Each doStep integrates the compiled
 * right-hand side with the core's Dormand-Prince 5(4) stepper and KneeSimulator's tolerances, the commands held;
 * a step that fails (a domain check, a collapsed step size) is refused and the state kept. With a dead time the
 * commands reach the actuators delay late (mk_run.c, mk_delay_*): each step is cut where a command given earlier
 * arrives, as KneeSimulator.step cuts it, and each piece integrated with the commands then in force.
 *
 * Built with valve inputs (model-spec 7d; VR_ue defined): the inputs ue, uf are the valves' openings, which the
 * core's valve-input variants take where the others take the commands (their right-hand side traced with the
 * openings, clipped to [-1, 1]); the pressures start at the parameters Pe0, Pf0. The air switched off (no variant
 * for the parameters) and a dead time are refused at initialization, in the library's words (generated).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"
#include "mk_run.h"

#define AUX_N 0    /* n in use (given or derived) */
#define AUX_LOW 1  /* end stop positions [m] */
#define AUX_HIGH 2

#ifdef VR_ue
#define MK_INPUT_E VR_ue
#define MK_INPUT_F VR_uf
#define MK_START_E VR_Pe0
#define MK_START_F VR_Pf0
int mk_variant(const double *p);
extern const char MK_FMU_VALVE_AIR_MESSAGE[];
extern const char MK_FMU_VALVE_DELAY_MESSAGE[];
#else
#define MK_INPUT_E VR_pe_cmd
#define MK_INPUT_F VR_pf_cmd
#define MK_START_E VR_pe_cmd /* the lag pressures start at the commands */
#define MK_START_F VR_pf_cmd
#endif

static void params_of(const mk_data *d, double *p) { mk_param_vector(d, d->aux[AUX_N], p); }

/* the two inputs the core's knee functions take now: the valves' openings, or the commands (with a dead time
 * those in force now) */
void mk_knee_inputs(const mk_data *d, double *u)
{
#ifdef VR_ue
    u[0] = d->v[VR_ue];
    u[1] = d->v[VR_uf];
#else
    mk_seen_commands(d, u);
#endif
}

int mk_model_start(mk_data *d, char *msg, size_t size)
{
    double p[MK_NPARAM], X0, low, high, stops[2];
    char a[40], detail[MK_MESSAGE - 64];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    d->aux[AUX_N] = mk_turns(d);
    params_of(d, p);
#ifdef VR_ue
    if (mk_variant(p) < 0) { /* the valve-input variants are the air's: without the air there is none */
        snprintf(msg, size, "%s", MK_FMU_VALVE_AIR_MESSAGE);
        return 1;
    }
    if (d->dl.delay > 0) {
        snprintf(msg, size, "%s", MK_FMU_VALVE_DELAY_MESSAGE);
        return 1;
    }
#endif
    X0 = d->v[VR_X0];
    if (X0 == mk_variables[VR_X0].start && mk_fmu_X_from_alpha(p, MK_FMU_DEFAULT_ALPHA, &X0, &fault) != 0) {
        mk_fault_message(&fault, detail, sizeof detail);
        snprintf(msg, size, "invalid start X0 at alpha = 60 deg: %s", detail);
        return 1;
    }
    low = fabs(d->v[VR_Lo] - d->v[VR_Lu]);
    high = d->v[VR_Lo] + d->v[VR_Lu];
    if (!(low < X0 && X0 < high)) { /* knee.beta_from_X's check, with its message */
        snprintf(msg, size, "invalid start X0 = %s m: hip height X = %s m is outside (%g, %g) m (the leg cannot "
                 "fold flat or stretch past straight)", mk_repr(X0, a, sizeof a), a, low, high);
        return 1;
    }
    if (mk_stop_positions(p, stops, &fault) != 0) {
        mk_fault_message(&fault, detail, sizeof detail);
        snprintf(msg, size, "the end stops are outside the model's domain: %s", detail);
        return 1;
    }
    d->aux[AUX_LOW] = stops[0];
    d->aux[AUX_HIGH] = stops[1];
    d->s.ny = mk_knee_nstate(p);
    d->s.y[0] = X0;
    d->s.y[1] = 0.0;
    d->s.y[2] = d->v[MK_START_E];
    d->s.y[3] = d->v[MK_START_F];
    d->s.h = MK_FMU_KNEE_H0;
    d->s.k1_valid = 0;
    /* every actuator length in 0 < L < b, finite pressures */
    if (mk_model_outputs(d, detail, sizeof detail) != 0) {
        snprintf(msg, size, "the start state is outside the model's domain: %s", detail);
        return 1;
    }
    return 0;
}

int mk_model_step(mk_data *d, double dt, char *msg, size_t size)
{
    double p[MK_NPARAM], seen[MK_MAX_COMMANDS], end, start, stop, h;
    mk_state s = d->s;
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    params_of(d, p);
    if (!(d->dl.delay > 0)) {
        if (mk_knee_step(p, d->aux + AUX_LOW, s.y, dt, d->v[MK_INPUT_E], d->v[MK_INPUT_F], MK_FMU_KNEE_RTOL,
                         MK_FMU_KNEE_ATOL, &s.h, s.k, &s.k1_valid, &s.k_pe, &s.k_pf, &fault) != 0) {
            mk_fault_message(&fault, msg, size);
            d->s.k1_valid = 0;
            return 1; /* the state as it was */
        }
        s.time += dt;
        d->s = s;
        return 0;
    }
    /* a dead time: KneeSimulator.step, the step cut where a command given earlier arrives */
    if (mk_delay_give(d, s.time, msg, size) != 0)
        return 1;
    end = s.time + dt;
    for (start = s.time;; start = stop) {
        stop = mk_delay_next_cut(d, start, end);
        mk_delay_at(d, start, seen);
        h = stop < end ? stop - start : end - s.time;
        if (h > 0) {
            if (mk_knee_step(p, d->aux + AUX_LOW, s.y, h, seen[0], seen[1], MK_FMU_KNEE_RTOL, MK_FMU_KNEE_ATOL, &s.h,
                             s.k, &s.k1_valid, &s.k_pe, &s.k_pf, &fault) != 0) {
                mk_fault_message(&fault, msg, size);
                d->s.k1_valid = 0;
                return 1; /* the state as it was (the command given stays: a step again from here replaces it) */
            }
            s.time += h;
        }
        if (!(stop < end)) break;
    }
    d->s = s;
    return 0;
}

int mk_model_outputs(mk_data *d, char *msg, size_t size)
{
    double p[MK_NPARAM], out[14], seen[MK_MAX_COMMANDS];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    params_of(d, p);
    mk_knee_inputs(d, seen); /* the openings, or the commands (with a dead time those in force now) */
    if (mk_knee_outputs(p, d->s.y, seen[0], seen[1], out, &fault) != 0) {
        mk_fault_message(&fault, msg, size);
        return 1;
    }
    d->v[VR_X] = out[0]; d->v[VR_V] = out[1]; d->v[VR_alpha] = out[2]; d->v[VR_beta] = out[3];
    d->v[VR_Le] = out[4]; d->v[VR_Lf] = out[5]; d->v[VR_fe] = out[6]; d->v[VR_ff] = out[7];
    d->v[VR_Pe] = out[8]; d->v[VR_Pf] = out[9]; d->v[VR_F] = out[10]; d->v[VR_a1] = out[11];
    d->v[VR_a2] = out[12]; d->v[VR_stable] = out[13] != 0;
#ifdef VR_qe /* built with the air (mkctl.native.fmu, air): each muscle's air mass flow, generated */
    {
        int mk_fmu_air_flows(const double *p, double Pe, double Pf, double pe_cmd, double pf_cmd, double *out,
                             mk_fault *fault);
        double q[2];
        if (mk_fmu_air_flows(p, out[8], out[9], seen[0], seen[1], q, &fault) != 0) {
            mk_fault_message(&fault, msg, size);
            return 1;
        }
        d->v[VR_qe] = q[0];
        d->v[VR_qf] = q[1];
    }
#endif
    return 0;
}

void mk_model_fallback_outputs(mk_data *d)
{
    double p[MK_NPARAM], posture[4];
    mk_fault fault;
    int vr;
    for (vr = 0; vr < NV; vr++)
        if (mk_variables[vr].causality == MK_OUTPUT) d->v[vr] = mk_variables[vr].type == MK_BOOLEAN ? 0.0 : NAN;
    if (!d->started || d->failed) return;
    params_of(d, p);
    if (mk_fmu_posture(p, d->s.y[0], posture, &fault) == 0) {
        d->v[VR_X] = d->s.y[0]; d->v[VR_V] = d->s.y[1]; d->v[VR_alpha] = posture[0]; d->v[VR_beta] = posture[1];
        d->v[VR_Le] = posture[2]; d->v[VR_Lf] = posture[3];
    }
}
