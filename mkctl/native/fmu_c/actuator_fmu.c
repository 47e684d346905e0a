/* The actuator's part of the native McKibbenActuator FMU: the run of mkctl.physics.simulate.ActuatorSimulator.
 *
 * The pressure (with an effect that has pressure dynamics, a lag) is the only state, advanced over each step with
 * the command held (the core's mk_actuator_lagged_pressure, generated from actuator.pressure_after); the tension (mk_actuator_tension) follows from the inputs L, Ldot and the
 * present pressure (the command itself without a lag). n left at its start value while b, L0 or D0 change
 * follows them. Start inputs outside the model's domain are refused at initialization; a step that ends outside
 * it (0 < L < b) is refused and the state kept. With a dead time the command reaches the actuator delay late
 * (mk_run.c, mk_delay_*): the step is cut where a command given earlier arrives, as ActuatorSimulator.step cuts it.
 *
 * Built with the air (model-spec 4d, 7d; VR_q defined): with an effect that moves the air on, the pressure is a
 * state of the muscle's mass balance at the inputs L, Ldot, held with the command over the step, integrated by
 * the generated actuator_air.c (mkctl/native/fmu.py, actuator_air_source) as ActuatorSimulator integrates it; the
 * output q is its air mass flow. Built with valve inputs (VR_u defined) the command is the valve's opening u and
 * the pressure starts at the parameter P_start; the air switched off and a dead time are refused at initialization.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"
#include "mk_run.h"

#define AUX_N 0

static void params_of(const mk_data *d, double *p) { mk_param_vector(d, d->aux[AUX_N], p); }

#ifdef VR_u
#define MK_COMMAND VR_u
#define MK_START VR_P_start
#else
#define MK_COMMAND VR_p_cmd
#define MK_START VR_p_cmd /* the lag (and the air) start at the command */
#endif

#ifdef VR_q /* built with the air: the generated actuator_air.c */
int mk_fmu_actuator_air_on(const double *p);
int mk_fmu_actuator_air_step(const double *p, double P, double P_cmd, double L, double Ldot, double dt, double *out,
                             mk_fault *fault);
int mk_fmu_actuator_air_flow(const double *p, double P, double P_cmd, double *out, mk_fault *fault);
void mk_fmu_actuator_air_fault(const mk_fault *fault, char *msg, size_t size);
#endif
#ifdef VR_u
int mk_variant(const double *p);
extern const char MK_FMU_VALVE_AIR_MESSAGE[];
#endif

/* the command the actuator acts on now: the valve's opening, or the pressure command (with a dead time the one in
 * force now) */
void mk_actuator_command(const mk_data *d, double *c)
{
#ifdef VR_u
    c[0] = d->v[VR_u];
#else
    mk_seen_commands(d, c);
#endif
}

/* the pressure after dt from P with the command c held (and L, Ldot: the air) */
static int pressure_after(const mk_data *d, const double *p, double P, double c, double dt, double *out, char *msg,
                          size_t size)
{
    mk_fault fault = {0, 0, 0, 0, 0, 0};
#ifdef VR_q
    if (mk_fmu_actuator_air_on(p)) {
        if (mk_fmu_actuator_air_step(p, P, c, d->v[VR_L], d->v[VR_Ldot], dt, out, &fault) != 0) {
            mk_fmu_actuator_air_fault(&fault, msg, size);
            return 1;
        }
        return 0;
    }
#else
    (void)d;
#endif
    if (mk_actuator_lagged_pressure(p, P, c, dt, out, &fault) != 0) {
        mk_fault_message(&fault, msg, size);
        return 1;
    }
    return 0;
}

int mk_model_start(mk_data *d, char *msg, size_t size)
{
    char detail[MK_MESSAGE - 64];
    double p[MK_NPARAM];
    d->aux[AUX_N] = mk_turns(d);
    params_of(d, p);
#ifdef VR_u
    if (mk_variant(p) < 0 || !mk_fmu_actuator_air_on(p)) { /* the valve drives nothing without the air */
        snprintf(msg, size, "%s", MK_FMU_VALVE_AIR_MESSAGE);
        return 1;
    }
    if (d->dl.delay > 0) {
        snprintf(msg, size, "an actuator FMU with valve inputs carries no dead time (model-spec 4b): set it to 0");
        return 1;
    }
#endif
    d->s.ny = 1;
    d->s.y[0] = d->v[MK_START];
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
    params_of(d, p);
    if (!(d->dl.delay > 0)) {
        if (pressure_after(d, p, d->s.y[0], d->v[MK_COMMAND], dt, &P, msg, size) != 0)
            return 1;
    } else { /* a dead time: ActuatorSimulator.step, the step cut where a command given earlier arrives */
        if (mk_delay_give(d, d->s.time, msg, size) != 0)
            return 1;
        P = d->s.y[0];
        end = d->s.time + dt;
        for (start = d->s.time;; start = stop) {
            stop = mk_delay_next_cut(d, start, end);
            mk_delay_at(d, start, seen);
            if (pressure_after(d, p, P, seen[0], stop - start, &P, msg, size) != 0)
                return 1;
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
    mk_actuator_command(d, seen); /* the opening, or the command (with a dead time the one in force now) */
    P = mk_pressure_is_state(p) ? d->s.y[0] : seen[0];
    if (mk_actuator_tension(p, d->v[VR_L], P, d->v[VR_Ldot], &f, &fault) != 0) {
        mk_fault_message(&fault, msg, size);
        return 1;
    }
    d->v[VR_f] = f;
    d->v[VR_P] = P;
#ifdef VR_q
    d->v[VR_q] = 0.0;
    if (mk_fmu_actuator_air_on(p) && mk_fmu_actuator_air_flow(p, P, seen[0], &d->v[VR_q], &fault) != 0) {
        mk_fmu_actuator_air_fault(&fault, msg, size);
        return 1;
    }
#endif
    return 0;
}

void mk_model_fallback_outputs(mk_data *d)
{
    d->v[VR_f] = NAN;
    d->v[VR_P] = NAN;
#ifdef VR_q
    d->v[VR_q] = NAN;
#endif
}
