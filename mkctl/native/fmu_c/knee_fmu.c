/* The knee's part of the native McKibbenKnee FMU: the run of mkctl.physics.simulate.KneeSimulator, in C.
 *
 * Start (as fmu/mckibben_knee.py): n left at its start value follows b, L0, D0; X0 left at its start value is the
 * hip height at alpha = 60 deg of the geometry; the leg starts at rest, the lag pressures at the commands. The
 * end stops engage at alpha = 5 and 75 deg (mkctl.physics.knee). Each doStep integrates the compiled right-hand
 * side with the adaptive Dormand-Prince 5(4) stepper of the core (rtol 1e-10, atol 1 nm, 1 nm/s, 1 mPa), the
 * commands held; a step that leaves the model's domain is refused and the state kept.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"

#define AUX_N 0      /* n in use (given or derived) */
#define AUX_LOW 1    /* end stop positions [m] */
#define AUX_HIGH 2

static void params_of(const mk_data *d, mk_params *p)
{
    p->b = d->v[VR_b]; p->n = d->aux[AUX_N]; p->L0 = d->v[VR_L0]; p->D0 = d->v[VR_D0];
    p->C1 = d->v[VR_C1]; p->C2 = d->v[VR_C2]; p->t0 = d->v[VR_t0]; p->m = d->v[VR_m];
    p->L1 = d->v[VR_L1]; p->L2 = d->v[VR_L2]; p->L5 = d->v[VR_L5]; p->L6 = d->v[VR_L6];
    p->Lo = d->v[VR_Lo]; p->Lu = d->v[VR_Lu]; p->Lec = d->v[VR_Lec]; p->Lfc = d->v[VR_Lfc];
    p->r = d->v[VR_r]; p->g = d->v[VR_g]; p->c = d->v[VR_c]; p->Fc = d->v[VR_Fc]; p->vs = d->v[VR_vs];
    p->tau = d->v[VR_tau]; p->model = (int)d->v[VR_model];
}

int mk_model_start(mk_data *d, char *msg, size_t size)
{
    mk_params p;
    double X0, low, high, stops[2];
    char a[40], detail[MK_MESSAGE];
    d->aux[AUX_N] = d->v[VR_n] == mk_variables[VR_n].start ? mk_core_derived_turns(d->v[VR_b], d->v[VR_L0], d->v[VR_D0])
                                                            : d->v[VR_n];
    params_of(d, &p);
    X0 = d->v[VR_X0] == mk_variables[VR_X0].start ? mk_core_X_from_alpha(&p, MK_DEFAULT_ALPHA) : d->v[VR_X0];
    low = fabs(p.Lo - p.Lu);
    high = p.Lo + p.Lu;
    if (!(low < X0 && X0 < high)) {
        snprintf(msg, size, "invalid start X0 = %s m: hip height X = %s m is outside (%g, %g) m (the leg cannot "
                 "fold flat or stretch past straight)", mk_repr(X0, a, sizeof a), mk_repr(X0, detail, 40), low, high);
        return 1;
    }
    stops[0] = mk_core_X_from_alpha(&p, MK_ALPHA_STOP_LOW);
    stops[1] = mk_core_X_from_alpha(&p, MK_ALPHA_STOP_HIGH);
    d->aux[AUX_LOW] = stops[0];
    d->aux[AUX_HIGH] = stops[1];
    d->s.ny = p.tau > 0 ? 4 : 2;
    d->s.y[0] = X0;
    d->s.y[1] = 0.0;
    d->s.y[2] = d->v[VR_pe_cmd];
    d->s.y[3] = d->v[VR_pf_cmd];
    d->s.h = 1e-3;
    /* every actuator length in 0 < L < b, finite pressures */
    if (mk_model_outputs(d, detail, sizeof detail) != 0) {
        snprintf(msg, size, "the start state is outside the model's domain: %s", detail);
        return 1;
    }
    return 0;
}

int mk_model_step(mk_data *d, double dt, char *msg, size_t size)
{
    mk_params p;
    mk_state s = d->s;
    params_of(d, &p);
    if (mk_core_knee_step(&p, d->aux + AUX_LOW, d->v[VR_pe_cmd], d->v[VR_pf_cmd], s.y, s.ny, dt, &s.h, msg, size)
        != 0)
        return 1; /* d->s untouched */
    s.time += dt;
    d->s = s;
    return 0;
}

int mk_model_outputs(mk_data *d, char *msg, size_t size)
{
    mk_params p;
    double out[MK_KNEE_N_OUTPUTS], Pe, Pf;
    params_of(d, &p);
    Pe = p.tau > 0 ? d->s.y[2] : d->v[VR_pe_cmd];
    Pf = p.tau > 0 ? d->s.y[3] : d->v[VR_pf_cmd];
    if (mk_core_knee_outputs(&p, d->s.y[0], d->s.y[1], Pe, Pf, out, msg, size) != 0) return 1;
    d->v[VR_X] = out[0]; d->v[VR_V] = out[1]; d->v[VR_alpha] = out[2]; d->v[VR_beta] = out[3];
    d->v[VR_Le] = out[4]; d->v[VR_Lf] = out[5]; d->v[VR_fe] = out[6]; d->v[VR_ff] = out[7];
    d->v[VR_Pe] = out[8]; d->v[VR_Pf] = out[9]; d->v[VR_F] = out[10]; d->v[VR_a1] = out[11]; d->v[VR_a2] = out[12];
    d->v[VR_stable] = out[11] < 0 && out[12] < 0;
    return 0;
}

void mk_model_fallback_outputs(mk_data *d)
{
    mk_params p;
    double posture[6];
    int vr;
    for (vr = 0; vr < NV; vr++)
        if (mk_variables[vr].causality == MK_OUTPUT) d->v[vr] = mk_variables[vr].type == MK_BOOLEAN ? 0.0 : NAN;
    if (!d->started || d->failed) return;
    params_of(d, &p);
    if (mk_core_knee_posture(&p, d->s.y[0], posture) == 0) {
        d->v[VR_X] = d->s.y[0]; d->v[VR_V] = d->s.y[1]; d->v[VR_alpha] = posture[0]; d->v[VR_beta] = posture[1];
        d->v[VR_Le] = posture[2]; d->v[VR_Lf] = posture[3];
    }
}
