/* The run's checks and the Model Exchange functions shared by every FMI wrapper (see mk_run.h). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"
#include "mk_run.h"

static int is_pressure_input(int vr)
{
    int k;
    for (k = 0; k < mk_n_pressure_inputs; k++)
        if (mk_pressure_inputs[k] == vr) return 1;
    return 0;
}

static int negative_pressure(const mk_data *d, int vr, char *msg, size_t size)
{
    char value[40];
    if (!(d->v[vr] < 0) || !is_pressure_input(vr)) return 0;
    snprintf(msg, size, MK_NEGATIVE_PRESSURE_FORMAT, mk_variables[vr].name, mk_repr(d->v[vr], value, sizeof value));
    return 1;
}

int mk_check_inputs(const mk_data *d, char *msg, size_t size)
{
    char value[40];
    int k, vr;
    for (k = 0; k < mk_n_inputs; k++) {
        vr = mk_inputs[k];
        if (!isfinite(d->v[vr])) {
            snprintf(msg, size, "input %s = %s %s is not a finite number", mk_variables[vr].name,
                     mk_repr(d->v[vr], value, sizeof value), mk_variables[vr].unit);
            return 1;
        }
        if (negative_pressure(d, vr, msg, size)) return 1;
    }
    return 0;
}

int mk_check_start_inputs(const mk_data *d, char *msg, size_t size)
{
    int k;
    for (k = 0; k < mk_n_inputs; k++)
        if (negative_pressure(d, mk_inputs[k], msg, size)) return 1;
    return 0;
}

int mk_compute_outputs(mk_data *d, char *msg, size_t size)
{
    double saved[NV];
    char value[40];
    int vr;
    memcpy(saved, d->v, sizeof saved);
    if (mk_model_outputs(d, msg, size) != 0) {
        memcpy(d->v, saved, sizeof saved);
        return 1;
    }
    for (vr = 0; vr < NV; vr++) {
        if (mk_variables[vr].causality == MK_OUTPUT && mk_variables[vr].type == MK_REAL && !isfinite(d->v[vr])) {
            snprintf(msg, size, MK_NON_FINITE_OUTPUT_FORMAT, mk_variables[vr].name,
                     mk_repr(d->v[vr], value, sizeof value), mk_variables[vr].unit);
            memcpy(d->v, saved, sizeof saved);
            return 1;
        }
    }
    return 0;
}

/* --- a dead time ------------------------------------------------------------------------------------------- */

#define RING(dl, k) (((dl)->first + (k)) % MK_HISTORY)
/* Model Exchange: the relative change of a command below which it is rounding noise of the host, not a new command */
#define MK_ME_COMMAND_ROUNDING 1e-13

/* Model Exchange's tolerance on an arrival time: a host that stops within it counts as at the arrival (fmpy takes
 * times within 1e-9 relative as equal, so it may stop a hair before a reported event time) */
static double arrival_tolerance(double t) { return 1e-9 * fabs(t); }

int mk_delay_start(mk_data *d, int discrete, char *msg, size_t size)
{
    mk_delay_line *dl = &d->dl;
    double p[MK_NPARAM], delay = 0.0;
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    int k;
    memset(dl, 0, sizeof *dl);
    mk_param_vector(d, mk_turns(d), p);
    if (mk_command_delay(p, &delay, &fault) != 0) {
        mk_fault_message(&fault, msg, size);
        return 1;
    }
    if (!(delay >= 0) || !isfinite(delay)) {
        char value[40];
        snprintf(msg, size, "the command delay %s s is not a finite number >= 0", mk_repr(delay, value, sizeof value));
        return 1;
    }
    if (mk_n_pressure_inputs > MK_MAX_COMMANDS) {
        snprintf(msg, size, "a dead time delays at most %d commands, this model has %d", MK_MAX_COMMANDS,
                 mk_n_pressure_inputs);
        return 1;
    }
    dl->delay = delay;
    dl->n = mk_n_pressure_inputs;
    dl->discrete = discrete;
    dl->first = 0;
    dl->count = 1;
    dl->arrives[0] = -INFINITY;
    for (k = 0; k < dl->n; k++) dl->command[0][k] = dl->seen[k] = d->v[mk_pressure_inputs[k]];
    dl->next_event = INFINITY;
    return 0;
}

int mk_delay_give(mk_data *d, double t, char *msg, size_t size)
{
    mk_delay_line *dl = &d->dl;
    double arrives = t + dl->delay;
    int k, last, same = 1;
    if (dl->count < 1) return 0; /* no run */
    while (dl->count > 1 && dl->arrives[RING(dl, 1)] <= t) { /* no longer in force at t: forgotten */
        dl->first = RING(dl, 1);
        dl->count--;
    }
    while (dl->count > 1 && dl->arrives[RING(dl, dl->count - 1)] >= arrives)
        dl->count--; /* a command given again at the same time (or earlier) replaces the later one */
    last = RING(dl, dl->count - 1);
    for (k = 0; k < dl->n; k++) {
        double was = dl->command[last][k], now = d->v[mk_pressure_inputs[k]];
        /* Model Exchange: a change within the host's rounding (an input interpolated between equal values) is no
         * new command; Co-Simulation compares exactly, as CommandSchedule does */
        if (dl->discrete ? fabs(now - was) > MK_ME_COMMAND_ROUNDING * fmax(fabs(now), fabs(was)) : now != was)
            same = 0;
    }
    if (same) return 0;
    if (dl->count >= MK_HISTORY) {
        double oldest = dl->arrives[RING(dl, 1)] - dl->delay;
        snprintf(msg, size, "the dead time delay = %g s would hold more than %d changes of the commands on their way "
                 "(given from t = %g s to t = %g s): give the commands at most every %g s (delay / %d), or use the "
                 "pythonfmu FMU", dl->delay, MK_HISTORY - 1, oldest, t, dl->delay / (MK_HISTORY - 1),
                 MK_HISTORY - 1);
        return 1;
    }
    last = RING(dl, dl->count);
    dl->arrives[last] = arrives;
    for (k = 0; k < dl->n; k++) dl->command[last][k] = d->v[mk_pressure_inputs[k]];
    dl->count++;
    return 0;
}

void mk_delay_at(const mk_data *d, double t, double *command)
{
    const mk_delay_line *dl = &d->dl;
    int k, i = RING(dl, 0);
    for (k = 1; k < dl->count && dl->arrives[RING(dl, k)] <= t; k++) i = RING(dl, k);
    for (k = 0; k < dl->n; k++) command[k] = dl->command[i][k];
}

double mk_delay_next_cut(const mk_data *d, double t0, double t1)
{
    const mk_delay_line *dl = &d->dl;
    int k;
    for (k = 0; k < dl->count; k++) {
        double a = dl->arrives[RING(dl, k)];
        if (t0 < a && a < t1) return a;
        if (a >= t1) break;
    }
    return t1;
}

void mk_seen_commands(const mk_data *d, double *command)
{
    int k;
    if (!(d->dl.delay > 0) || d->dl.count < 1) {
        for (k = 0; k < mk_n_pressure_inputs && k < MK_MAX_COMMANDS; k++) command[k] = d->v[mk_pressure_inputs[k]];
    } else if (d->dl.discrete) {
        for (k = 0; k < d->dl.n; k++) command[k] = d->dl.seen[k];
    } else {
        mk_delay_at(d, d->s.time, command);
    }
}

double mk_delay_event_update(mk_data *d, double t)
{
    mk_delay_line *dl = &d->dl;
    double reached = t + arrival_tolerance(t), next = INFINITY;
    int k;
    if (!(dl->delay > 0) || dl->count < 1) return INFINITY;
    mk_delay_at(d, reached, dl->seen);
    for (k = 0; k < dl->count; k++) {
        double a = dl->arrives[RING(dl, k)];
        if (a > reached) {
            next = a;
            break;
        }
    }
    dl->next_event = next;
    return next;
}

int mk_delay_event_needed(const mk_data *d, double t)
{
    const mk_delay_line *dl = &d->dl;
    double reached = t + arrival_tolerance(t), now[MK_MAX_COMMANDS];
    int k;
    if (!(dl->delay > 0) || dl->count < 1) return 0;
    mk_delay_at(d, reached, now);
    for (k = 0; k < dl->n; k++)
        if (now[k] != dl->seen[k]) return 1; /* arrived, not yet seen: the host passed an event time */
    for (k = 0; k < dl->count; k++) {
        double a = dl->arrives[RING(dl, k)];
        if (a > reached) return a < dl->next_event; /* the next arrival, not reported yet */
    }
    return 0;
}

/* --- Model Exchange --------------------------------------------------------------------------------------- */

int mk_me_check_start(const mk_data *d, char *msg, size_t size)
{
    char value[40];
    int k, vr;
    (void)value;
    for (k = 0; k < mk_n_me_refused; k++) {
        vr = mk_me_refused[k].vr;
        if (d->v[vr] != 0) {
            snprintf(msg, size, "Model Exchange cannot run %s = %s %s: %s", mk_variables[vr].name,
                     mk_repr(d->v[vr], value, sizeof value), mk_variables[vr].unit, mk_me_refused[k].reason);
            return 1;
        }
    }
    return 0;
}

void mk_me_get_states(const mk_data *d, double *x)
{
    int i;
    for (i = 0; i < MK_ME_NX; i++) x[i] = d->s.y[i];
}

void mk_me_set_states(mk_data *d, const double *x)
{
    int i;
    for (i = 0; i < MK_ME_NX; i++) d->s.y[i] = x[i];
    d->s.k1_valid = 0; /* the integrator's stored derivative no longer belongs to the state */
    d->outputs_fresh = 0;
}

void mk_me_get_nominals(double *nominal)
{
    int i;
    for (i = 0; i < MK_ME_NX; i++) nominal[i] = mk_me_nominal[i];
}

int mk_me_derivatives(const mk_data *d, double *dx, char *msg, size_t size)
{
    char value[40];
    int i;
    if (mk_check_inputs(d, msg, size) != 0 || mk_model_derivatives(d, dx, msg, size) != 0) return 1;
    for (i = 0; i < MK_ME_NX; i++) {
        if (!isfinite(dx[i])) {
            const mk_variable *v = &mk_variables[mk_me_derivative_vr[i]];
            snprintf(msg, size, "%s = %s %s is not a finite number", v->name, mk_repr(dx[i], value, sizeof value),
                     v->unit);
            return 1;
        }
    }
    return 0;
}

int mk_me_event_indicators(const mk_data *d, double *z, char *msg, size_t size)
{
    if (MK_ME_NZ == 0) return 0;
    if (mk_check_inputs(d, msg, size) != 0) return 1;
    return mk_model_event_indicators(d, z, msg, size);
}

int mk_me_update_locals(mk_data *d, char *msg, size_t size)
{
    double dx[MK_ME_NX];
    int i;
    for (i = 0; i < MK_ME_NX; i++)
        if (mk_variables[mk_me_state_vr[i]].causality == MK_LOCAL) d->v[mk_me_state_vr[i]] = d->s.y[i];
    if (mk_me_derivatives(d, dx, msg, size) != 0) return 1;
    for (i = 0; i < MK_ME_NX; i++) d->v[mk_me_derivative_vr[i]] = dx[i];
    return 0;
}
