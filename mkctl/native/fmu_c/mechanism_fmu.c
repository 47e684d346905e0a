/* A mechanism's part of its native McKibben<Name> FMU (model-spec sections 3b, 7d): the run of
 * mkctl.physics.mechanism.simulate_mechanism, in C. No equation here: the right-hand side, the outputs, the stops
 * and the integrator are generated into mechanism_core.c by mkctl/native/mechanism_fmu.py.
 *
 * Start: n left at its start value while b, L0 or D0 change follows them; the own parameters are checked as
 * Mechanism.bind checks them; q0 is the start coordinate (at rest), the lag pressures at the commands; the end
 * stops are the mechanism's at the present parameters (q_min < q_max, as Mechanism.stop_positions asks). Each
 * doStep integrates the generated right-hand side with the core's Dormand-Prince 5(4) stepper and
 * simulate_mechanism's tolerances, the commands held; a step that fails is refused and the state kept. With a
 * dead time the commands reach the muscles delay late (mk_run.c), each step cut where a command arrives. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"
#include "mk_run.h"
#include "mechanism_core.h"

#define AUX_N 0    /* n in use (given or derived) */
#define AUX_LOW 1  /* end stops [m or rad] */
#define AUX_HIGH 2

static void params_of(const mk_data *d, double *p) { mk_param_vector(d, d->aux[AUX_N], p); }

/* the commands of the muscles (one muscle: the first, given twice) */
static void commands_of(const double *seen, double *c) { c[0] = seen[0]; c[1] = seen[mk_mech_muscles - 1]; }

void mk_mech_seen_commands(const mk_data *d, double *c)
{
    double seen[MK_MAX_COMMANDS];
    int k;
    if (d->dl.delay > 0) {
        mk_seen_commands(d, seen); /* the pressure commands in force now, a dead time late */
    } else {
        for (k = 0; k < mk_mech_muscles; k++) seen[k] = d->v[mk_mech_command_vr[k]]; /* pressures or tensions */
    }
    commands_of(seen, c);
}

void mk_mech_fault_message(const mk_fault *fault, char *msg, size_t size)
{
    if (fault->code == 1 && fault->check >= 0 && fault->check < mk_mech_fault_count)
        mk_fault_format(mk_mech_fault_templates[fault->check], fault, msg, size);
    else
        mk_fault_message(fault, msg, size);
}

int mk_mech_setup(const mk_data *d, double *p, double *stops, char *msg, size_t size)
{
    char detail[MK_MESSAGE - 64];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    mk_param_vector(d, mk_turns(d), p);
    if (mk_mech_check_parameters(p, msg, size) != 0) return 1;
    if (mk_mech_stops(p, stops, &fault) != 0) {
        mk_mech_fault_message(&fault, detail, sizeof detail);
        snprintf(msg, size, "the end stops are outside the model's domain: %s", detail);
        return 1;
    }
    if (!(isfinite(stops[0]) && isfinite(stops[1]) && stops[0] < stops[1])) {
        snprintf(msg, size, MK_MECH_STOPS_FORMAT, stops[0], stops[1]);
        return 1;
    }
    return 0;
}

int mk_model_start(mk_data *d, char *msg, size_t size)
{
    double p[MK_NPARAM], stops[2];
    char detail[MK_MESSAGE - 64];
    int k;
    d->aux[AUX_N] = mk_turns(d);
    if (mk_mech_setup(d, p, stops, msg, size) != 0) return 1;
    if (!isfinite(d->v[mk_mech_q0_vr])) {
        snprintf(msg, size, "parameter q0 must be a finite number");
        return 1;
    }
    d->aux[AUX_LOW] = stops[0];
    d->aux[AUX_HIGH] = stops[1];
    d->s.ny = mk_mech_nstate(p);
    d->s.y[0] = d->v[mk_mech_q0_vr];
    d->s.y[1] = 0.0;
    d->s.y[2] = d->s.y[3] = 0.0;
    for (k = 0; k < mk_mech_muscles; k++) d->s.y[2 + k] = d->v[mk_mech_command_vr[k]];
    d->s.h = MK_MECH_H0; /* simulate_mechanism's first step */
    d->s.k1_valid = 0;
    if (mk_model_outputs(d, detail, sizeof detail) != 0) { /* every length in 0 < L < b, finite pressures */
        snprintf(msg, size, "the start state is outside the model's domain: %s", detail);
        return 1;
    }
    return 0;
}

static int step_piece(mk_data *d, mk_state *s, const double *p, double h, const double *seen, char *msg,
                      size_t size)
{
    double c[2];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    commands_of(seen, c);
    if (mk_mech_step(p, d->aux + AUX_LOW, s->y, h, c[0], c[1], MK_MECH_RTOL, &s->h, s->k, &s->k1_valid, &s->k_pe,
                     &s->k_pf, &fault) != 0) {
        mk_mech_fault_message(&fault, msg, size);
        d->s.k1_valid = 0;
        return 1;
    }
    return 0;
}

int mk_model_step(mk_data *d, double dt, char *msg, size_t size)
{
    double p[MK_NPARAM], seen[MK_MAX_COMMANDS], end, start, stop, h;
    mk_state s = d->s;
    int k;
    params_of(d, p);
    if (!(d->dl.delay > 0)) {
        for (k = 0; k < mk_mech_muscles; k++) seen[k] = d->v[mk_mech_command_vr[k]];
        if (step_piece(d, &s, p, dt, seen, msg, size) != 0) return 1; /* the state as it was */
        s.time += dt;
        d->s = s;
        return 0;
    }
    if (mk_delay_give(d, s.time, msg, size) != 0) return 1;
    end = s.time + dt;
    for (start = s.time;; start = stop) {
        stop = mk_delay_next_cut(d, start, end);
        mk_delay_at(d, start, seen);
        h = stop < end ? stop - start : end - s.time;
        if (h > 0) {
            if (step_piece(d, &s, p, h, seen, msg, size) != 0) return 1;
            s.time += h;
        }
        if (!(stop < end)) break;
    }
    d->s = s;
    return 0;
}

int mk_model_outputs(mk_data *d, char *msg, size_t size)
{
    double p[MK_NPARAM], out[16], c[2];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    int i;
    params_of(d, p);
    mk_mech_seen_commands(d, c);
    if (mk_mech_outputs(p, d->s.y, c[0], c[1], out, &fault) != 0) {
        mk_mech_fault_message(&fault, msg, size);
        return 1;
    }
    d->v[mk_mech_output_vr[0]] = d->s.y[0];
    d->v[mk_mech_output_vr[1]] = d->s.y[1];
    for (i = 0; i < mk_mech_nout; i++) d->v[mk_mech_output_vr[2 + i]] = out[i]; /* "stable" as 1.0 or 0.0 */
    return 0;
}

void mk_model_fallback_outputs(mk_data *d)
{
    int vr;
    for (vr = 0; vr < NV; vr++)
        if (mk_variables[vr].causality == MK_OUTPUT) d->v[vr] = mk_variables[vr].type == MK_BOOLEAN ? 0.0 : NAN;
    if (!d->started || d->failed) return;
    d->v[mk_mech_output_vr[0]] = d->s.y[0];
    d->v[mk_mech_output_vr[1]] = d->s.y[1];
}
