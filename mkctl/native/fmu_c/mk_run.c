/* The run's checks and the Model Exchange functions shared by every FMI wrapper (see mk_run.h). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
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

/* --- Model Exchange --------------------------------------------------------------------------------------- */

int mk_me_check_start(const mk_data *d, char *msg, size_t size)
{
    char value[40];
    int k, vr;
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
