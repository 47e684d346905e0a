/* FMI 2.0 interface of mkctl's native FMUs, Co-Simulation and Model Exchange: the part both FMUs share.
 *
 * The model's part (knee_fmu.c, actuator_fmu.c) builds a run from the parameters, steps it and computes the
 * outputs, with the compiled core generated from mkctl's equations (mkctl/native); its Model Exchange part
 * (knee_me.c, actuator_me.c) gives the derivatives and event indicators. The checks of a run and the Model
 * Exchange logic every wrapper shares are in mk_run.c. This file does the rest the way mkctl's pythonfmu slaves
 * (mkctl/fmu/slave.py) do, so that both FMUs answer alike:
 *
 * - parameters are checked at exitInitializationMode with the rules of mkctl.physics.params.Params; a bad one is
 *   logged ("invalid parameters: parameter m must be positive, got -1.0") and answered with fmi2Error, and every
 *   later doStep with fmi2Error and the message again;
 * - doStep refuses an input that is not a finite number, a negative pressure input, a step that would leave the
 *   model's domain, or one whose outputs would not be finite numbers, with a logged message and fmi2Discard, the
 *   state left as it was at the start of the step; fmi2GetBooleanStatus(fmi2Terminated) then answers true, so a
 *   host such as fmpy's simulate_fmu ends the run there (model-spec section 7c) instead of retrying the same step
 *   for ever; a host driving the FMU call by call can still set a valid input and step again;
 * - Model Exchange: fmi2GetDerivatives and fmi2GetEventIndicators answer fmi2Error with a logged message when the
 *   inputs or the state are outside the model's domain, and fmi2CompletedIntegratorStep and fmi2NewDiscreteStates
 *   then ask the host to terminate; a parameter Model Exchange cannot represent (mk_me_refused) is refused at
 *   fmi2ExitInitializationMode;
 * - a dead time (delay > 0): Co-Simulation keeps the commands given at each doStep and cuts a step where one
 *   arrives; Model Exchange takes the pressure inputs as given at every fmi2CompletedIntegratorStep and
 *   fmi2NewDiscreteStates (at the time of the host's last fmi2SetTime; what a host sets while its integrator
 *   searches, between them, is not a command given), and the commands the actuators see are a discrete state
 *   switched at time events (nextEventTime of fmi2NewDiscreteStates; fmi2CompletedIntegratorStep asks for event
 *   mode when a command given there must be announced); mk_run.c, mk_delay_*;
 * - outputs are computed when read, from the state and the present inputs (direct feedthrough);
 * - messages with status fmi2Discard or worse always reach the host's logger; others only with logging on.
 *
 * FMU state: fmi2GetFMUstate copies the instance's data (every variable, the integrator's state and step size),
 * so a replay from a saved state is identical; serialization is a plain copy of the same bytes.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "mk_fmu.h"
#include "mk_run.h"

#define MK_MAGIC 0x6d6b63746c463032ULL /* "mkctlF02": the start of a serialized state */

typedef struct {
    mk_data d;
    fmi2CallbackFunctions cb;
    char *name;
    int logging_on;
    int categories; /* bit mask of the enabled log categories */
    int me;         /* instantiated for Model Exchange (else Co-Simulation) */
    char me_logged[MK_MESSAGE]; /* the last Model Exchange failure logged (each is logged once, not per call) */
} mk_instance;

static const char *CATEGORIES[] = {"logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal",
                                   "logAll"};
#define N_CATEGORIES 5

/* --- logging ------------------------------------------------------------------------------------------ */

static void mk_log(mk_instance *inst, fmi2Status status, const char *fmt, ...)
{
    char raw[2 * MK_MESSAGE], message[4 * MK_MESSAGE];
    const char *category;
    size_t i, j;
    int index;
    va_list args;
    if (inst == NULL || inst->cb.logger == NULL) return;
    switch (status) {
    case fmi2Warning: index = 0; break;
    case fmi2Discard: index = 1; break;
    case fmi2Error: index = 2; break;
    case fmi2Fatal: index = 3; break;
    default: index = 4; break;
    }
    category = CATEGORIES[index];
    /* errors and refusals always reach the host; the rest only with logging on and the category enabled */
    if (status < fmi2Discard && !(inst->logging_on && (inst->categories & ((1 << index) | (1 << 4)))))
        return;
    va_start(args, fmt);
    vsnprintf(raw, sizeof raw, fmt, args);
    va_end(args);
    /* The message is passed as the format itself, already formatted: hosts that cannot read variadic arguments
     * (ctypes: fmpy, pythonfmu's tests) see it whole. A '%' in it is doubled so that a printf-style host shows
     * it once. */
    for (i = 0, j = 0; raw[i] != '\0' && j + 2 < sizeof message; i++) {
        message[j++] = raw[i];
        if (raw[i] == '%') message[j++] = '%';
    }
    message[j] = '\0';
    inst->cb.logger(inst->cb.componentEnvironment, inst->name, status, category, message);
}

const char *mk_repr(double value, char *buffer, size_t size)
{
    int precision, exponent;
    char digits[40];
    if (isnan(value)) {
        snprintf(buffer, size, "nan");
        return buffer;
    }
    if (isinf(value)) {
        snprintf(buffer, size, value > 0 ? "inf" : "-inf");
        return buffer;
    }
    for (precision = 1; precision < 17; precision++) { /* the shortest digits that read back exactly */
        snprintf(digits, sizeof digits, "%.*e", precision - 1, value);
        if (strtod(digits, NULL) == value) break;
    }
    snprintf(digits, sizeof digits, "%.*e", precision - 1, value);
    exponent = atoi(strchr(digits, 'e') + 1);
    if (value != 0 && (exponent < -4 || exponent >= 16)) { /* Python's repr switches to 1e+16, 1e-05 */
        snprintf(buffer, size, "%s", digits);
    } else {
        int decimals = precision - 1 - exponent;
        snprintf(buffer, size, "%.*f", decimals > 0 ? decimals : 0, value);
        if (strchr(buffer, '.') == NULL && strlen(buffer) + 3 <= size) strcat(buffer, ".0");
    }
    return buffer;
}

/* --- life cycle -------------------------------------------------------------------------------------------- */

static void start_values(mk_data *d)
{
    int vr;
    memset(d, 0, sizeof *d);
    for (vr = 0; vr < NV; vr++) d->v[vr] = mk_variables[vr].start;
    d->phase = MK_INSTANTIATED;
}

static int finite_number(double x) { return isfinite(x); }

/* The rules of mkctl.physics.params.Params, in its order; 0 if the parameters are valid. */
static int check_parameters(const mk_data *d, char *msg, size_t size)
{
    char a[40], b[40];
    int k, vr;
#ifdef VR_P_rated
    if (!(isfinite(d->v[VR_P_rated]) && d->v[VR_P_rated] > 0)) { /* checked before Params, as the slave does */
        snprintf(msg, size, "parameter P_rated must be a positive number, got %s", mk_repr(d->v[VR_P_rated], a,
                 sizeof a));
        return 1;
    }
#endif
    for (k = 0; k < mk_n_params_order; k++) {
        vr = mk_params_order[k];
        if (!finite_number(d->v[vr])) {
            snprintf(msg, size, "parameter %s must be a finite number, got %s", mk_variables[vr].name,
                     mk_repr(d->v[vr], a, sizeof a));
            return 1;
        }
    }
    for (k = 0; k < mk_n_params_order; k++) {
        vr = mk_params_order[k];
        if (mk_variables[vr].rule == MK_POSITIVE && !(d->v[vr] > 0)) {
            snprintf(msg, size, "parameter %s must be positive, got %s", mk_variables[vr].name,
                     mk_repr(d->v[vr], a, sizeof a));
            return 1;
        }
    }
    for (k = 0; k < mk_n_params_order; k++) {
        vr = mk_params_order[k];
        if (mk_variables[vr].rule == MK_NOT_NEGATIVE && d->v[vr] < 0) {
            snprintf(msg, size, "parameter %s must not be negative, got %s", mk_variables[vr].name,
                     mk_repr(d->v[vr], a, sizeof a));
            return 1;
        }
    }
    for (k = 0; k < mk_n_range_rules; k++) {
        const mk_range_rule *rule = &mk_range_rules[k];
        if (!(d->v[rule->vr] >= rule->low && d->v[rule->vr] <= rule->high)) {
            snprintf(msg, size, rule->message, d->v[rule->vr]);
            return 1;
        }
    }
    for (k = 0; k < mk_n_integer_rules; k++) {
        const mk_integer_rule *rule = &mk_integer_rules[k];
        if (d->v[rule->vr] < rule->low || d->v[rule->vr] > rule->high) {
            snprintf(msg, size, rule->message, (int)d->v[rule->vr]);
            return 1;
        }
    }
    if (d->v[VR_L0] >= d->v[VR_b]) {
        snprintf(msg, size, "rest length L0 = %s m must be shorter than the braid b = %s m",
                 mk_repr(d->v[VR_L0], a, sizeof a), mk_repr(d->v[VR_b], b, sizeof b));
        return 1;
    }
    if (d->v[VR_t0] >= d->v[VR_D0] / 2) {
        snprintf(msg, size, "wall thickness t0 = %s m must be less than the radius D0/2",
                 mk_repr(d->v[VR_t0], a, sizeof a));
        return 1;
    }
    if (d->v[VR_n] != mk_variables[VR_n].start && !(d->v[VR_n] > 0)) {
        snprintf(msg, size, "parameter n must be positive, got %s", mk_repr(d->v[VR_n], a, sizeof a));
        return 1;
    }
    return 0;
}

static fmi2Status update_outputs(mk_instance *inst);

/* Warn once per excursion when a muscle's pressure is above P_rated (the pythonfmu slave's _check_rating). */
static void check_rating(mk_instance *inst, double time)
{
#ifdef VR_P_rated
    mk_data *d = &inst->d;
    int k;
    if (mk_n_pressure_outputs == 0 || update_outputs(inst) != fmi2OK) return;
    for (k = 0; k < mk_n_pressure_outputs && k < 4; k++) {
        double pressure = d->v[mk_pressure_outputs[k].vr];
        if (pressure > d->v[VR_P_rated] && !d->over_rating[k]) {
            d->over_rating[k] = 1;
            mk_log(inst, fmi2Warning, "t = %g s: %s pressure %s = %.4g MPa exceeds the rated pressure P_rated = "
                   "%.4g MPa", time, mk_pressure_outputs[k].muscle, mk_variables[mk_pressure_outputs[k].vr].name,
                   pressure / 1e6, d->v[VR_P_rated] / 1e6);
        } else if (pressure <= d->v[VR_P_rated]) {
            d->over_rating[k] = 0;
        }
    }
#else
    (void)inst;
    (void)time;
#endif
}

/* Build the run from the present values; on failure d->failed and d->error say why. */
static int start_run(mk_instance *inst)
{
    mk_data *d = &inst->d;
    char msg[MK_MESSAGE - 32];
    d->started = 1;
    d->failed = 0;
    d->outputs_fresh = 0;
    d->outputs_valid = 0;
    d->error[0] = '\0';
    memset(&d->s, 0, sizeof d->s);
    if (check_parameters(d, msg, sizeof msg) != 0) {
        snprintf(d->error, sizeof d->error, "invalid parameters: %s", msg);
        d->failed = 1;
    } else if (inst->me && mk_me_check_start(d, d->error, sizeof d->error) != 0) {
        d->failed = 1;
    } else if (mk_check_start_inputs(d, msg, sizeof msg) != 0) {
        snprintf(d->error, sizeof d->error, "invalid start inputs: %s", msg);
        d->failed = 1;
    } else if (mk_delay_start(d, inst->me, d->error, sizeof d->error) != 0) {
        d->failed = 1;
    } else if (mk_model_start(d, d->error, sizeof d->error) != 0) {
        d->failed = 1;
    } else if (mk_compute_outputs(d, msg, sizeof msg) != 0) {
        snprintf(d->error, sizeof d->error, "invalid start: %s", msg);
        d->failed = 1;
    }
    memset(d->over_rating, 0, sizeof d->over_rating);
    if (d->failed) mk_log(inst, fmi2Error, "%s", d->error);
    else check_rating(inst, 0.0);
    return d->failed;
}

static fmi2Status refuse(mk_instance *inst, fmi2Status status, const char *fmt, ...)
{
    char message[2 * MK_MESSAGE];
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof message, fmt, args);
    va_end(args);
    mk_log(inst, status, "%s", message);
    return status;
}

#define INSTANCE(c) mk_instance *inst = (mk_instance *)(c); if (inst == NULL) return fmi2Error

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    mk_instance *inst;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || instanceName == NULL) return NULL;
    inst = (mk_instance *)calloc(1, sizeof *inst);
    if (inst == NULL) return NULL;
    inst->cb = *functions;
    inst->name = (char *)malloc(strlen(instanceName) + 1);
    if (inst->name == NULL) {
        free(inst);
        return NULL;
    }
    strcpy(inst->name, instanceName);
    inst->logging_on = loggingOn ? 1 : 0;
    inst->categories = (1 << N_CATEGORIES) - 1;
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        mk_log(inst, fmi2Error, "%s: fmi2Instantiate with an unknown fmuType %d", MK_MODEL_NAME, (int)fmuType);
        free(inst->name);
        free(inst);
        return NULL;
    }
    inst->me = fmuType == fmi2ModelExchange;
    if (fmuGUID == NULL || strcmp(fmuGUID, MK_GUID) != 0) {
        mk_log(inst, fmi2Error, "wrong GUID %s: this binary is %s", fmuGUID ? fmuGUID : "(null)", MK_GUID);
        free(inst->name);
        free(inst);
        return NULL;
    }
    start_values(&inst->d);
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    mk_instance *inst = (mk_instance *)c;
    if (inst == NULL) return;
    free(inst->name);
    free(inst);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    size_t k;
    int j, mask = 0;
    INSTANCE(c);
    inst->logging_on = loggingOn ? 1 : 0;
    if (nCategories == 0) {
        inst->categories = (1 << N_CATEGORIES) - 1;
        return fmi2OK;
    }
    for (k = 0; k < nCategories; k++) {
        for (j = 0; j < N_CATEGORIES; j++)
            if (categories[k] != NULL && strcmp(categories[k], CATEGORIES[j]) == 0) break;
        if (j == N_CATEGORIES)
            return refuse(inst, fmi2Error, "fmi2SetDebugLogging: unknown log category %s",
                          categories[k] ? categories[k] : "(null)");
        mask |= 1 << j;
    }
    inst->categories = mask;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    INSTANCE(c);
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (inst->d.phase != MK_INSTANTIATED)
        return refuse(inst, fmi2Error, "fmi2SetupExperiment is allowed only right after fmi2Instantiate");
    inst->d.s.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    INSTANCE(c);
    if (inst->d.phase != MK_INSTANTIATED)
        return refuse(inst, fmi2Error, "fmi2EnterInitializationMode is allowed only after fmi2Instantiate");
    inst->d.phase = MK_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    double time;
    INSTANCE(c);
    if (inst->d.phase != MK_INITIALIZATION)
        return refuse(inst, fmi2Error, "fmi2ExitInitializationMode without fmi2EnterInitializationMode");
    time = inst->d.s.time;
    start_run(inst); /* logs any problem */
    inst->d.s.time = time;
    inst->d.phase = inst->me ? MK_EVENT_MODE : MK_STEPPING;
    return inst->d.failed ? fmi2Error : fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    INSTANCE(c);
    inst->d.phase = MK_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    INSTANCE(c);
    start_values(&inst->d);
    return fmi2OK;
}

/* --- values -------------------------------------------------------------------------------------------------- */

static fmi2Status check_vr(mk_instance *inst, fmi2ValueReference vr, int type, const char *what)
{
    static const char *TYPES[] = {"Real", "Integer", "Boolean"};
    if (vr >= NV) return refuse(inst, fmi2Error, "%s: no variable has value reference %u", what, vr);
    if (mk_variables[vr].type != type)
        return refuse(inst, fmi2Error, "%s: %s (value reference %u) is not a %s but a %s", what,
                      mk_variables[vr].name, vr, TYPES[type], TYPES[mk_variables[vr].type]);
    return fmi2OK;
}

/* Bring the outputs up to date; fmi2Warning (logged) if they cannot be computed. */
static fmi2Status update_outputs(mk_instance *inst)
{
    mk_data *d = &inst->d;
    char msg[MK_MESSAGE];
    if (d->outputs_fresh) return d->outputs_failed ? fmi2Warning : fmi2OK;
    if (!d->started) { /* outputs read in initialization mode: the run as the present values would start */
        double time = d->s.time;
        start_run(inst);
        d->s.time = time;
    }
    d->outputs_failed = 0;
    if (d->failed) {
        snprintf(msg, sizeof msg, "%s", d->error);
        d->outputs_failed = 1;
    } else if (mk_compute_outputs(d, msg, sizeof msg) != 0) {
        d->outputs_failed = 1;
    }
    if (d->outputs_failed) { /* always shown: never a silent NaN */
        if (d->outputs_valid) { /* the values in v[] are those of the last good computation */
            mk_log(inst, fmi2Error, "%s: %s; the outputs keep their last valid values", MK_UNDEFINED_OUTPUTS, msg);
        } else {
            mk_model_fallback_outputs(d);
            mk_log(inst, fmi2Error, "%s: %s", MK_UNDEFINED_OUTPUTS, msg);
        }
    } else {
        d->outputs_valid = 1;
    }
    d->outputs_fresh = 1;
    return d->outputs_failed ? fmi2Warning : fmi2OK;
}

/* Model Exchange's local variables (lag states, derivatives) up to date; fmi2Warning (logged) if they cannot be. */
static fmi2Status update_locals(mk_instance *inst)
{
    char msg[MK_MESSAGE];
    if (!inst->d.started) update_outputs(inst); /* builds the run */
    if (inst->d.failed) return fmi2Warning;
    if (mk_me_update_locals(&inst->d, msg, sizeof msg) != 0) {
        mk_log(inst, fmi2Error, "the derivatives are undefined: %s", msg);
        return fmi2Warning;
    }
    return fmi2OK;
}

static fmi2Status get_values(mk_instance *inst, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *what, double *out)
{
    size_t k;
    fmi2Status status = fmi2OK, s;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, vr[k], type, what) != fmi2OK) return fmi2Error;
        if (mk_variables[vr[k]].causality == MK_OUTPUT) {
            s = update_outputs(inst);
            if (s > status) status = s;
        } else if (mk_variables[vr[k]].causality == MK_LOCAL) {
            s = update_locals(inst);
            if (s > status) status = s;
        }
        out[k] = inst->d.v[vr[k]];
    }
    return status;
}

static fmi2Status set_value(mk_instance *inst, fmi2ValueReference vr, int type, double value, const char *what)
{
    mk_data *d = &inst->d;
    if (check_vr(inst, vr, type, what) != fmi2OK) return fmi2Error;
    if (mk_variables[vr].causality == MK_OUTPUT)
        return refuse(inst, fmi2Error, "%s: %s is an output and cannot be set", what, mk_variables[vr].name);
    if (mk_variables[vr].causality == MK_LOCAL)
        return refuse(inst, fmi2Error, "%s: %s is a local variable of Model Exchange and cannot be set (states: "
                      "fmi2SetContinuousStates)", what, mk_variables[vr].name);
    if (mk_variables[vr].causality == MK_PARAMETER) {
        if (d->phase != MK_INSTANTIATED && d->phase != MK_INITIALIZATION)
            return refuse(inst, fmi2Error, "%s: %s is a fixed parameter: set it before fmi2ExitInitializationMode "
                          "(or after fmi2Reset)", what, mk_variables[vr].name);
        d->started = 0; /* the run is built again from the new values */
    }
    d->v[vr] = value;
    d->outputs_fresh = 0;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    INSTANCE(c);
    if (nvr > 0 && (vr == NULL || value == NULL)) return fmi2Error;
    return get_values(inst, vr, nvr, MK_REAL, "fmi2GetReal", value);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    size_t k;
    fmi2Status status = fmi2OK;
    double x;
    INSTANCE(c);
    for (k = 0; k < nvr; k++) {
        fmi2Status s = get_values(inst, &vr[k], 1, MK_INTEGER, "fmi2GetInteger", &x);
        if (s == fmi2Error) return s;
        if (s > status) status = s;
        value[k] = (fmi2Integer)x;
    }
    return status;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    size_t k;
    fmi2Status status = fmi2OK;
    double x;
    INSTANCE(c);
    for (k = 0; k < nvr; k++) {
        fmi2Status s = get_values(inst, &vr[k], 1, MK_BOOLEAN, "fmi2GetBoolean", &x);
        if (s == fmi2Error) return s;
        if (s > status) status = s;
        value[k] = x != 0 ? fmi2True : fmi2False;
    }
    return status;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    INSTANCE(c);
    (void)value;
    if (nvr == 0) return fmi2OK;
    return refuse(inst, fmi2Error, "fmi2GetString: %s has no String variables (value reference %u)",
                  MK_MODEL_NAME, vr[0]);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    size_t k;
    INSTANCE(c);
    for (k = 0; k < nvr; k++)
        if (set_value(inst, vr[k], MK_REAL, value[k], "fmi2SetReal") != fmi2OK) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    size_t k;
    INSTANCE(c);
    for (k = 0; k < nvr; k++)
        if (set_value(inst, vr[k], MK_INTEGER, (double)value[k], "fmi2SetInteger") != fmi2OK) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    size_t k;
    INSTANCE(c);
    for (k = 0; k < nvr; k++)
        if (set_value(inst, vr[k], MK_BOOLEAN, value[k] ? 1.0 : 0.0, "fmi2SetBoolean") != fmi2OK) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    INSTANCE(c);
    (void)value;
    if (nvr == 0) return fmi2OK;
    return refuse(inst, fmi2Error, "fmi2SetString: %s has no String variables (value reference %u)",
                  MK_MODEL_NAME, vr[0]);
}

/* --- stepping -------------------------------------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    mk_data *d;
    mk_state saved;
    double saved_v[NV];
    char msg[MK_MESSAGE], a[40];
    INSTANCE(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    d = &inst->d;
    if (inst->me)
        return refuse(inst, fmi2Error, "doStep at t = %g s refused: this instance is Model Exchange",
                      currentCommunicationPoint);
    if (d->phase != MK_STEPPING)
        return refuse(inst, fmi2Error, "doStep at t = %g s refused: call fmi2ExitInitializationMode first "
                      "(or the instance was terminated)", currentCommunicationPoint);
    if (!d->started) start_run(inst); /* parameters set again after fmi2SetFMUstate */
    if (d->failed)
        return refuse(inst, fmi2Error, "doStep at t = %g s refused: %s", currentCommunicationPoint, d->error);
    d->refused = 1; /* until the step is done: fmi2Terminated answers true after any refusal below */
    if (mk_check_inputs(d, msg, sizeof msg) != 0)
        return refuse(inst, fmi2Discard, "doStep at t = %g s: %s", currentCommunicationPoint, msg);
    if (!(communicationStepSize >= 0))
        return refuse(inst, fmi2Discard, "doStep at t = %g s: negative step size %s s", currentCommunicationPoint,
                      mk_repr(communicationStepSize, a, sizeof a));
    if (communicationStepSize > 0) {
        saved = d->s;
        memcpy(saved_v, d->v, sizeof saved_v); /* a model part may write outputs while it steps */
        /* the step must succeed and end with finite outputs; if not, the state and values stay as they were */
        if (mk_model_step(d, communicationStepSize, msg, sizeof msg) != 0 ||
            mk_compute_outputs(d, msg, sizeof msg) != 0) {
            d->s = saved;
            memcpy(d->v, saved_v, sizeof saved_v);
            return refuse(inst, fmi2Discard, "doStep from t = %g s over %g s: %s", currentCommunicationPoint,
                          communicationStepSize, msg);
        }
        d->outputs_fresh = 1; /* computed just now, for the new state and the present inputs */
        d->outputs_failed = 0;
        d->outputs_valid = 1;
    }
    d->refused = 0;
    check_rating(inst, currentCommunicationPoint + communicationStepSize);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    INSTANCE(c);
    return refuse(inst, fmi2Error, "fmi2CancelStep: doStep never runs asynchronously here");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    INSTANCE(c);
    if (s == fmi2DoStepStatus) {
        *value = fmi2OK;
        return fmi2OK;
    }
    return refuse(inst, fmi2Discard, "fmi2GetStatus: status kind %d is not provided", (int)s);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    INSTANCE(c);
    if (s == fmi2LastSuccessfulTime) {
        *value = inst->d.s.time;
        return fmi2OK;
    }
    return refuse(inst, fmi2Discard, "fmi2GetRealStatus: status kind %d is not provided", (int)s);
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    INSTANCE(c);
    (void)value;
    return refuse(inst, fmi2Discard, "fmi2GetIntegerStatus: status kind %d is not provided", (int)s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    INSTANCE(c);
    if (s == fmi2Terminated) { /* true after a refused doStep: the host must not retry that step for ever */
        *value = inst->d.refused ? fmi2True : fmi2False;
        return fmi2OK;
    }
    return refuse(inst, fmi2Discard, "fmi2GetBooleanStatus: status kind %d is not provided", (int)s);
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    INSTANCE(c);
    (void)value;
    return refuse(inst, fmi2Discard, "fmi2GetStringStatus: status kind %d is not provided", (int)s);
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    INSTANCE(c);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return refuse(inst, fmi2Error, "fmi2SetRealInputDerivatives: inputs are held constant over a step "
                  "(canInterpolateInputs is false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    INSTANCE(c);
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return refuse(inst, fmi2Error, "fmi2GetRealOutputDerivatives: not provided (maxOutputDerivativeOrder is 0)");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    INSTANCE(c);
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return refuse(inst, fmi2Error, "fmi2GetDirectionalDerivative: not provided");
}

/* --- FMU state ---------------------------------------------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    mk_data *copy;
    INSTANCE(c);
    if (state == NULL) return fmi2Error;
    copy = (mk_data *)(*state != NULL ? *state : malloc(sizeof *copy));
    if (copy == NULL) return refuse(inst, fmi2Error, "fmi2GetFMUstate: out of memory");
    *copy = inst->d;
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    INSTANCE(c);
    if (state == NULL) return refuse(inst, fmi2Error, "fmi2SetFMUstate: no state given");
    inst->d = *(const mk_data *)state;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    (void)c;
    if (state != NULL && *state != NULL) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size)
{
    (void)c;
    (void)state;
    *size = sizeof(unsigned long long) + sizeof(mk_data);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte serializedState[], size_t size)
{
    unsigned long long magic = MK_MAGIC;
    INSTANCE(c);
    if (state == NULL || size < sizeof magic + sizeof(mk_data))
        return refuse(inst, fmi2Error, "fmi2SerializeFMUstate: no state, or a buffer of %lu bytes is too small",
                      (unsigned long)size);
    memcpy(serializedState, &magic, sizeof magic);
    memcpy(serializedState + sizeof magic, state, sizeof(mk_data));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *state)
{
    unsigned long long magic;
    mk_data *copy;
    INSTANCE(c);
    if (size != sizeof magic + sizeof(mk_data))
        return refuse(inst, fmi2Error, "fmi2DeSerializeFMUstate: %lu bytes are not a state of this FMU",
                      (unsigned long)size);
    memcpy(&magic, serializedState, sizeof magic);
    if (magic != MK_MAGIC)
        return refuse(inst, fmi2Error, "fmi2DeSerializeFMUstate: the bytes are not a state of this FMU");
    copy = (mk_data *)(*state != NULL ? *state : malloc(sizeof *copy));
    if (copy == NULL) return refuse(inst, fmi2Error, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(copy, serializedState + sizeof magic, sizeof *copy);
    *state = copy;
    return fmi2OK;
}

/* --- Model Exchange (model-spec section 7c) ------------------------------------------------------------------- */

#define ME_INSTANCE(c, what)                                                                                  \
    mk_instance *inst = (mk_instance *)(c);                                                                   \
    if (inst == NULL) return fmi2Error;                                                                       \
    if (!inst->me) return refuse(inst, fmi2Error, "%s: this instance is Co-Simulation", what)

/* Log a Model Exchange failure once (a host's integrator may call a function many times at the same point). */
static void log_me_failure(mk_instance *inst, fmi2Status status, const char *what, const char *msg)
{
    char key[MK_MESSAGE];
    snprintf(key, sizeof key, "%s: %s", what, msg); /* the same failure at another time is not logged again */
    if (strcmp(key, inst->me_logged) == 0) return;
    snprintf(inst->me_logged, sizeof inst->me_logged, "%s", key);
    mk_log(inst, status, "%s at t = %g s: %s", what, inst->d.s.time, msg);
}

/* The run as the present values build it (Model Exchange functions may be called in initialization mode). */
static int me_ready(mk_instance *inst)
{
    if (!inst->d.started) {
        double time = inst->d.s.time;
        start_run(inst);
        inst->d.s.time = time;
    }
    return !inst->d.failed;
}

/* Whether the run must end here (inputs or state outside the model's domain), with the reason logged. */
static int me_must_terminate(mk_instance *inst, const char *what)
{
    double dx[MK_ME_NX];
    char msg[MK_MESSAGE];
    if (!me_ready(inst)) {
        log_me_failure(inst, fmi2Error, what, inst->d.error);
        return 1;
    }
    if (mk_me_derivatives(&inst->d, dx, msg, sizeof msg) != 0) {
        char text[MK_MESSAGE + 64];
        snprintf(text, sizeof text, "%s; the simulation must end here", msg);
        log_me_failure(inst, fmi2Discard, what, text);
        return 1;
    }
    return 0;
}

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    ME_INSTANCE(c, "fmi2EnterEventMode");
    if (inst->d.phase != MK_EVENT_MODE && inst->d.phase != MK_CONTINUOUS_TIME_MODE)
        return refuse(inst, fmi2Error, "fmi2EnterEventMode is allowed only after fmi2ExitInitializationMode");
    inst->d.phase = MK_EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info)
{
    char msg[MK_MESSAGE];
    ME_INSTANCE(c, "fmi2NewDiscreteStates");
    if (info == NULL) return refuse(inst, fmi2Error, "fmi2NewDiscreteStates: no fmi2EventInfo given");
    /* the right-hand side switches by itself (an event only restarts the host's integrator), but for a dead time:
     * the commands the actuators see switch now to those in force, and the next arrival is a time event */
    info->newDiscreteStatesNeeded = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    if (me_ready(inst) && inst->d.dl.delay > 0 && mk_check_inputs(&inst->d, msg, sizeof msg) == 0) {
        double next; /* the commands given now (bad inputs end the run below) */
        if (mk_delay_give(&inst->d, inst->d.s.time, msg, sizeof msg) != 0) {
            info->terminateSimulation = fmi2True;
            return refuse(inst, fmi2Error, "fmi2NewDiscreteStates at t = %g s: %s", inst->d.s.time, msg);
        }
        next = mk_delay_event_update(&inst->d, inst->d.s.time);
        inst->d.outputs_fresh = 0;
        if (isfinite(next)) {
            info->nextEventTimeDefined = fmi2True;
            info->nextEventTime = next;
        }
    }
    info->terminateSimulation = me_must_terminate(inst, "fmi2NewDiscreteStates") ? fmi2True : fmi2False;
    if (!info->terminateSimulation) check_rating(inst, inst->d.s.time);
    return inst->d.failed ? fmi2Error : fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    ME_INSTANCE(c, "fmi2EnterContinuousTimeMode");
    if (inst->d.phase != MK_EVENT_MODE)
        return refuse(inst, fmi2Error, "fmi2EnterContinuousTimeMode is allowed only in event mode");
    inst->d.phase = MK_CONTINUOUS_TIME_MODE;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    int terminate;
    ME_INSTANCE(c, "fmi2CompletedIntegratorStep");
    (void)noSetFMUStatePriorToCurrentPoint;
    terminate = me_must_terminate(inst, "fmi2CompletedIntegratorStep");
    if (!terminate && inst->d.dl.delay > 0) { /* a dead time: the commands given now */
        char msg[MK_MESSAGE];
        if (mk_delay_give(&inst->d, inst->d.s.time, msg, sizeof msg) != 0) {
            if (terminateSimulation != NULL) *terminateSimulation = fmi2True;
            return refuse(inst, fmi2Error, "fmi2CompletedIntegratorStep at t = %g s: %s", inst->d.s.time, msg);
        }
    }
    /* ... to be announced as a time event (or one has arrived that the host passed) */
    if (enterEventMode != NULL)
        *enterEventMode = !terminate && mk_delay_event_needed(&inst->d, inst->d.s.time) ? fmi2True : fmi2False;
    if (terminateSimulation != NULL) *terminateSimulation = terminate ? fmi2True : fmi2False;
    if (!terminate) check_rating(inst, inst->d.s.time);
    return inst->d.failed ? fmi2Error : fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    ME_INSTANCE(c, "fmi2SetTime");
    inst->d.s.time = time;
    inst->d.outputs_fresh = 0;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    ME_INSTANCE(c, "fmi2SetContinuousStates");
    if (nx != MK_ME_NX || (nx > 0 && x == NULL))
        return refuse(inst, fmi2Error, "fmi2SetContinuousStates: %s has %d continuous states, not %lu", MK_MODEL_NAME,
                      MK_ME_NX, (unsigned long)nx);
    if (!me_ready(inst))
        return refuse(inst, fmi2Error, "fmi2SetContinuousStates refused: %s", inst->d.error);
    mk_me_set_states(&inst->d, x);
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    char msg[MK_MESSAGE];
    size_t i;
    ME_INSTANCE(c, "fmi2GetDerivatives");
    if (nx != MK_ME_NX || (nx > 0 && derivatives == NULL))
        return refuse(inst, fmi2Error, "fmi2GetDerivatives: %s has %d continuous states, not %lu", MK_MODEL_NAME,
                      MK_ME_NX, (unsigned long)nx);
    if (!me_ready(inst)) {
        log_me_failure(inst, fmi2Error, "fmi2GetDerivatives", inst->d.error);
        return fmi2Error;
    }
    if (mk_me_derivatives(&inst->d, derivatives, msg, sizeof msg) != 0) {
        for (i = 0; i < nx; i++) derivatives[i] = NAN; /* never a number that looks valid */
        log_me_failure(inst, fmi2Error, "fmi2GetDerivatives", msg);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    char msg[MK_MESSAGE];
    size_t i;
    ME_INSTANCE(c, "fmi2GetEventIndicators");
    if (ni != MK_ME_NZ || (ni > 0 && eventIndicators == NULL))
        return refuse(inst, fmi2Error, "fmi2GetEventIndicators: %s has %d event indicators, not %lu", MK_MODEL_NAME,
                      MK_ME_NZ, (unsigned long)ni);
    if (ni == 0) return fmi2OK;
    if (!me_ready(inst)) {
        log_me_failure(inst, fmi2Error, "fmi2GetEventIndicators", inst->d.error);
        return fmi2Error;
    }
    if (mk_me_event_indicators(&inst->d, eventIndicators, msg, sizeof msg) != 0) {
        for (i = 0; i < ni; i++) eventIndicators[i] = NAN;
        log_me_failure(inst, fmi2Error, "fmi2GetEventIndicators", msg);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    ME_INSTANCE(c, "fmi2GetContinuousStates");
    if (nx != MK_ME_NX || (nx > 0 && x == NULL))
        return refuse(inst, fmi2Error, "fmi2GetContinuousStates: %s has %d continuous states, not %lu", MK_MODEL_NAME,
                      MK_ME_NX, (unsigned long)nx);
    if (!me_ready(inst))
        return refuse(inst, fmi2Error, "fmi2GetContinuousStates refused: %s", inst->d.error);
    mk_me_get_states(&inst->d, x);
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    ME_INSTANCE(c, "fmi2GetNominalsOfContinuousStates");
    if (nx != MK_ME_NX || (nx > 0 && x_nominal == NULL))
        return refuse(inst, fmi2Error, "fmi2GetNominalsOfContinuousStates: %s has %d continuous states, not %lu",
                      MK_MODEL_NAME, MK_ME_NX, (unsigned long)nx);
    mk_me_get_nominals(x_nominal);
    return fmi2OK;
}
