/* The FMI 2.0 wrapper of mkctl's native FMUs: what the generic part (fmi2_wrapper.c, mk_run.c) and a model's
 * part (knee_fmu.c and knee_me.c, or actuator_fmu.c and actuator_me.c) share. Written by mkctl/native/fmu.py's build, see docs/fmu.md.
 *
 * Every variable lives in one array of doubles indexed by its value reference (Integer and Boolean values as
 * whole numbers); model_variables.h (generated from the pythonfmu slave's interface) gives the value references
 * as VR_<name>, the count NV and the table mk_variables[] (name, type, causality, unit, start value).
 */
#ifndef MK_FMU_H
#define MK_FMU_H

#include <stddef.h>

enum mk_type { MK_REAL, MK_INTEGER, MK_BOOLEAN };
enum mk_causality { MK_INPUT, MK_PARAMETER, MK_OUTPUT, MK_LOCAL /* Model Exchange's states, derivatives */ };
/* checks of a Real parameter, the rules of mkctl.physics.params.Params */
enum mk_rule { MK_ANY, MK_POSITIVE, MK_NOT_NEGATIVE };

typedef struct {
    const char *name;
    int type;      /* enum mk_type */
    int causality; /* enum mk_causality */
    int rule;      /* enum mk_rule (parameters) */
    const char *unit;
    double start;
} mk_variable;

#include "model_variables.h" /* generated: MK_MODEL_NAME, MK_GUID, MK_UNDEFINED_OUTPUTS, NV, VR_<name> */

extern const mk_variable mk_variables[NV];   /* by value reference */
extern const int mk_params_order[];          /* the Real parameters, in the order Params checks them */
extern const int mk_n_params_order;
extern const int mk_inputs[];                /* the inputs, checked at every doStep */
extern const int mk_n_inputs;
/* the Integer parameters' allowed range (low <= value <= high) and Params' message, "%d" for the value */
typedef struct {
    int vr;
    int low, high;
    const char *message;
} mk_integer_rule;
extern const mk_integer_rule mk_integer_rules[];
extern const int mk_n_integer_rules;
/* the Real parameters with a range (the model's domain): low <= value <= high, else the message (%.6g: the value) */
typedef struct {
    int vr;
    double low, high;
    const char *message;
} mk_range_rule;
extern const mk_range_rule mk_range_rules[];
extern const int mk_n_range_rules;
/* the pressure outputs checked against P_rated (none when the FMU has no P_rated) */
typedef struct {
    int vr;
    const char *muscle;
} mk_pressure_output;
extern const mk_pressure_output mk_pressure_outputs[];
extern const int mk_n_pressure_outputs;

#define MK_MAX_STATES 4
#define MK_MESSAGE 600

/* What determines the future of a run: the integrator's state. */
typedef struct {
    double time;
    double y[MK_MAX_STATES]; /* knee: X, V (and Pe, Pf with a lag); actuator: P */
    int ny;
    double h;                /* the integrator's next step size [s] */
    double k[28];            /* first-same-as-last: the derivative at y (7 stages x 4 states) */
    int k1_valid;
    double k_pe, k_pf;       /* the commands k was computed with */
} mk_state;

/* A dead time (model-spec section 4b, dead_time): the pressure commands on their way to the actuators, as
 * mkctl.physics.simulate.CommandSchedule keeps them. Each change of the commands given at time t arrives at
 * t + delay; before the first change arrives the start commands hold. A ring of at most MK_HISTORY changes (those
 * not yet arrived and the one in force), inside the FMU state. Functions in mk_run.c (mk_delay_*). */
#define MK_HISTORY 2048
#define MK_MAX_COMMANDS 2
typedef struct {
    double delay;                  /* [s]; 0: no dead time, the actuators see the inputs themselves */
    int n;                         /* commands: the pressure inputs (knee 2, actuator 1) */
    int discrete;                  /* Model Exchange: the seen commands are a discrete state, updated at events */
    int first, count;              /* the changes e[first], ..., e[first + count - 1] (mod MK_HISTORY), count >= 1 */
    double arrives[MK_HISTORY];    /* when each change reaches the actuators [s] (-inf: the start commands) */
    double command[MK_HISTORY][MK_MAX_COMMANDS];
    double seen[MK_MAX_COMMANDS];  /* Model Exchange: the commands the actuators see since the last event */
    double next_event;             /* Model Exchange: the next event time last reported to the host (inf: none) */
} mk_delay_line;

/* Everything an FMU state holds (fmi2GetFMUstate copies it whole). */
typedef struct {
    double v[NV];            /* every variable, by value reference */
    mk_state s;
    double aux[8];           /* model constants computed at start (derived n, end stops, ...) */
    int phase;               /* enum mk_phase */
    int started;             /* the model was built from the present parameter values */
    int failed;              /* ... and that failed: error says why */
    int outputs_fresh;       /* the outputs in v[] belong to the present state and inputs */
    int outputs_failed;
    int outputs_valid;       /* v[] holds outputs of a good computation since the start (kept when one fails) */
    int over_rating[4];      /* per pressure output: above P_rated now (warned once per excursion) */
    int refused;             /* the last doStep was refused: fmi2Terminated answers true, so the host ends there */
    char error[MK_MESSAGE];
    mk_delay_line dl;        /* the commands on their way through a dead time */
} mk_data;

enum mk_phase { MK_INSTANTIATED, MK_INITIALIZATION, MK_STEPPING, MK_TERMINATED,
                MK_EVENT_MODE, MK_CONTINUOUS_TIME_MODE /* Model Exchange */ };

/* The model's part. Each returns 0 on success, or nonzero with a one-line message in msg. */
/* Build the run from the parameters and inputs in d->v (parameter checks done): derived values, start state. */
int mk_model_start(mk_data *d, char *msg, size_t size);
/* Advance d->s by dt > 0 with the inputs held; on failure d->s is left as it was. */
int mk_model_step(mk_data *d, double dt, char *msg, size_t size);
/* Write every output into d->v from d->s and the present inputs. */
int mk_model_outputs(mk_data *d, char *msg, size_t size);
/* Outputs when mk_model_outputs failed: what can still be said (posture), NaN for the rest. */
void mk_model_fallback_outputs(mk_data *d);

/* The core's parameter vector (every field of Params in order): the FMU's values, n as given or derived,
 * the fields the FMU does not have at Params' defaults (generated in model_variables.c). */
void mk_param_vector(const mk_data *d, double n, double *p);

/* n in use: left at its start value while b, L0 or D0 changed, derived from them (derived_turns); else as given */
double mk_turns(const mk_data *d);

/* Helpers the wrapper offers the models. */
/* Python's repr of a double (shortest round-trip digits, "1.0" not "1"), for messages that read like mkctl's. */
const char *mk_repr(double value, char *buffer, size_t size);

#endif
