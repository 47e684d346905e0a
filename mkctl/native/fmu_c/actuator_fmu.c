/* The actuator's part of the native McKibbenActuator FMU: the run of mkctl.physics.simulate.ActuatorSimulator.
 *
 * The pressure (with an effect that has pressure dynamics, a lag) is the only state, advanced over each step with
 * the command held (the core's mk_actuator_lagged_pressure, generated from actuator.pressure_after); the tension (mk_actuator_tension) follows from the inputs L, Ldot and the
 * present pressure (the command itself without a lag). n left at its start value while b, L0 or D0 change
 * follows them. Start inputs outside the model's domain are refused at initialization; a step that ends outside
 * it (0 < L < b) is refused and the state kept. With a dead time the command reaches the actuator delay late
 * (mk_run.c, mk_delay_*): the step is cut where a command given earlier arrives, as ActuatorSimulator.step cuts it.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"
#include "mk_run.h"

#define AUX_N 0

static void params_of(const mk_data *d, double *p) { mk_param_vector(d, d->aux[AUX_N], p); }

int mk_model_start(mk_data *d, char *msg, size_t size)
{
    char detail[MK_MESSAGE - 64];
    double p[MK_NPARAM];
    d->aux[AUX_N] = mk_turns(d);
    params_of(d, p);
    d->s.ny = 1;
    d->s.y[0] = d->v[VR_p_cmd];
    if (mk_model_outputs(d, detail, sizeof detail) != 0) { /* 0 < L < b, a finite pressure */
        snprintf(msg, size, "the start inputs are outside the model's domain: %s", detail);
        return 1;
    }
    return 0;
}

int mk_model_step(mk_data *d, double dt, char *msg, size_t size)
{
    double p[MK_NPARAM], P, seen[MK_MAX_COMMANDS], start, stop, end;
    mk_state saved = d->s;
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    params_of(d, p);
    if (!(d->dl.delay > 0)) {
        if (mk_actuator_lagged_pressure(p, d->s.y[0], d->v[VR_p_cmd], dt, &P, &fault) != 0) {
            mk_fault_message(&fault, msg, size);
            return 1;
        }
    } else { /* a dead time: ActuatorSimulator.step, the step cut where a command given earlier arrives */
        if (mk_delay_give(d, d->s.time, msg, size) != 0)
            return 1;
        P = d->s.y[0];
        end = d->s.time + dt;
        for (start = d->s.time;; start = stop) {
            stop = mk_delay_next_cut(d, start, end);
            mk_delay_at(d, start, seen);
            if (mk_actuator_lagged_pressure(p, P, seen[0], stop - start, &P, &fault) != 0) {
                mk_fault_message(&fault, msg, size);
                return 1;
            }
            if (!(stop < end)) break;
        }
    }
    d->s.y[0] = P;
    d->s.time += dt;
    if (mk_model_outputs(d, msg, size) != 0) { /* the step must end in the model's domain */
        d->s = saved;
        return 1;
    }
    return 0;
}

int mk_model_outputs(mk_data *d, char *msg, size_t size)
{
    double p[MK_NPARAM], P, f, seen[MK_MAX_COMMANDS];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    params_of(d, p);
    mk_seen_commands(d, seen); /* the command, or with a dead time the one in force now */
    P = mk_pressure_is_state(p) ? d->s.y[0] : seen[0];
    if (mk_actuator_tension(p, d->v[VR_L], P, d->v[VR_Ldot], &f, &fault) != 0) {
        mk_fault_message(&fault, msg, size);
        return 1;
    }
    d->v[VR_f] = f;
    d->v[VR_P] = P;
    return 0;
}

void mk_model_fallback_outputs(mk_data *d)
{
    d->v[VR_f] = NAN;
    d->v[VR_P] = NAN;
}
