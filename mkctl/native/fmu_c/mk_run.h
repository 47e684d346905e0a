/* The run's checks and the Model Exchange functions of mkctl's native FMUs, shared by every FMI wrapper (the FMI 2.0
 * one, fmi2_wrapper.c, and any other): plain functions on the instance's data (mk_fmu.h), implemented in mk_run.c.
 * No model and no effect is named here: the model parts (knee_me.c, actuator_me.c) call the generated core, and the
 * tables they read are generated into model_variables.c by mkctl/native/fmu.py.
 *
 * Model Exchange (model-spec section 7c): the continuous states x are the first MK_ME_NX entries of the core's
 * state vector (mk_state.y: the knee's X, V, Pe_lag, Pf_lag; the actuator's P_lag), their derivatives the
 * generated right-hand side, MK_ME_NZ event indicators where that right-hand side switches.
 * Each int function returns 0 on success, or nonzero with a one-line message in msg. */
#ifndef MK_RUN_H
#define MK_RUN_H

#include <stddef.h>

#include "mk_fmu.h"

/* generated into model_variables.c */
extern const int mk_pressure_inputs[];              /* the inputs that are gauge pressures (-1 ends the list) */
extern const int mk_n_pressure_inputs;
extern const char MK_NEGATIVE_PRESSURE_FORMAT[];    /* the slaves' message: %s name, %s value */
extern const char MK_NON_FINITE_OUTPUT_FORMAT[];    /* the slaves' message: %s name, %s value, %s unit */
extern const int mk_me_state_vr[MK_ME_NX];          /* the variable of each continuous state */
extern const int mk_me_derivative_vr[MK_ME_NX];     /* its der(...) variable */
extern const double mk_me_nominal[MK_ME_NX];
typedef struct {
    int vr;
    const char *reason;
} mk_me_refusal;
extern const mk_me_refusal mk_me_refused[];         /* parameters Model Exchange refuses when not 0 */
extern const int mk_n_me_refused;

/* --- checks of a run (Co-Simulation and Model Exchange) --- */
/* every input a finite number, and no pressure input below 0 */
int mk_check_inputs(const mk_data *d, char *msg, size_t size);
/* no pressure input below 0 (at the start; a start input that is not a number is the model's to refuse) */
int mk_check_start_inputs(const mk_data *d, char *msg, size_t size);
/* every output into d->v from the state and inputs (mk_model_outputs), all Real ones finite numbers; on failure
 * the outputs in d->v are left as they were */
int mk_compute_outputs(mk_data *d, char *msg, size_t size);

/* --- a dead time (mk_fmu.h: mk_delay_line; model-spec section 4b) --- */
/* the delay line of a new run: the delay of the present parameters, the start commands (the pressure inputs) in
 * force until the first change arrives; discrete: Model Exchange (the seen commands change only at events) */
int mk_delay_start(mk_data *d, int discrete, char *msg, size_t size);
/* the present commands given at time t (CommandSchedule.give): changes arriving at or after t + delay are
 * replaced, those no longer in force at t forgotten; 1 with a message when the line cannot hold one more change */
int mk_delay_give(mk_data *d, double t, char *msg, size_t size);
/* the commands in force at time t: the last change arrived at or before t (CommandSchedule.at) */
void mk_delay_at(const mk_data *d, double t, double *command);
/* the first arrival of a change in (t0, t1), else t1: where a step from t0 to t1 is cut (CommandSchedule.pieces) */
double mk_delay_next_cut(const mk_data *d, double t0, double t1);
/* the commands the actuators see now: the inputs without a dead time; with one, in Co-Simulation those in force at
 * d->s.time, in Model Exchange the discrete state (the commands in force at the last event) */
void mk_seen_commands(const mk_data *d, double *command);
/* Model Exchange, at an event at time t: the seen commands become those in force at t; returns the next arrival
 * after t (inf when none), remembered as the event time reported to the host */
double mk_delay_event_update(mk_data *d, double t);
/* Model Exchange: 1 when the host must enter event mode at t (a change given since the last event arrives before
 * the event time reported then, or a change has arrived that the seen commands do not have yet) */
int mk_delay_event_needed(const mk_data *d, double t);

/* --- Model Exchange --- */
/* what Model Exchange cannot run (mk_me_refused: none today), refused at initialization */
int mk_me_check_start(const mk_data *d, char *msg, size_t size);
void mk_me_get_states(const mk_data *d, double *x);            /* x[MK_ME_NX] */
void mk_me_set_states(mk_data *d, const double *x);
void mk_me_get_nominals(double *nominal);
/* dx[MK_ME_NX] at the present time, states and inputs: inputs checked, every derivative finite */
int mk_me_derivatives(const mk_data *d, double *dx, char *msg, size_t size);
/* z[MK_ME_NZ] */
int mk_me_event_indicators(const mk_data *d, double *z, char *msg, size_t size);
/* the values of Model Exchange's local variables in d->v (the lag states, the derivatives) */
int mk_me_update_locals(mk_data *d, char *msg, size_t size);

/* --- the model's Model Exchange part (knee_me.c, actuator_me.c) --- */
int mk_model_derivatives(const mk_data *d, double *dx, char *msg, size_t size);        /* MK_ME_NX values */
int mk_model_event_indicators(const mk_data *d, double *z, char *msg, size_t size);    /* MK_ME_NZ values */

#endif
