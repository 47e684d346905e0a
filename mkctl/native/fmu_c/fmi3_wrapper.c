/* FMI 3.0 interface of mkctl's native FMUs (dist/fmi3/McKibbenKnee.fmu and McKibbenActuator.fmu, model-spec 7c).
 *
 * The FMI 3.0 functions are a thin layer over the FMI 2.0 implementation (fmi2_wrapper.c, included below under
 * other names: mk2_fmi2Instantiate, ..., not exported), over the same model parts and the same compiled core. So
 * an FMI 3.0 FMU checks its parameters and inputs, steps, refuses and logs exactly as its FMI 2.0 twin, and
 * gives the same numbers: one implementation, two interfaces. What differs is FMI 3.0's:
 *
 * - fmi3InstantiateCoSimulation takes the log callback directly (messages are passed on as they are, the
 *   names of FMI 2.0 functions in them replaced by their FMI 3.0 counterparts);
 * - fmi3EnterInitializationMode takes the experiment's times (fmi2SetupExperiment + fmi2EnterInitializationMode);
 * - Float64 = Real, Int32 = Integer, Boolean (a C bool) = Boolean; the other types have no variables here;
 * - fmi3DoStep: a step the FMU refuses returns fmi3Discard with terminateSimulation = true and lastSuccessfulTime
 *   at the start of the step (the state is kept there): the host ends the run, it never retries the same step;
 *   a failed start (a bad parameter) returns fmi3Error at every step, as in FMI 2.0;
 * - Model Exchange maps one to one (fmi3UpdateDiscreteStates = fmi2NewDiscreteStates, ...); FMI 3.0 declares the
 *   event indicators as variables, readable with fmi3GetFloat64 too;
 * - Co-Simulation has no event mode; no clocks, no intermediate update, no early return, no directional
 *   derivatives: refused with a message.
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmi2Functions.h"

/* The FMI 2.0 functions under their own names: fmi2Functions.h names every function through fmi2FullName. */
#undef fmi2FullName
#define fmi2FullName(name) mk2_##name
#include "fmi2_wrapper.c"

/* FMI 3.0's independent variable "time" (modelDescription.xml, mkctl/native/fmi3.py): the value reference after
 * the model's variables (0 .. NV - 1) */
#define MK3_VR_TIME NV
/* the event indicators, declared as variables in FMI 3.0: value references NV + 1 .. NV + MK_ME_NZ */
#define MK3_VR_EVENT_INDICATOR(k) (NV + 1 + (k))

typedef struct {
    fmi2Component c2;                 /* the FMI 2.0 instance doing the work */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
} mk3_instance;

/* --- messages ---------------------------------------------------------------------------------------------- */

/* FMI 2.0 function names in the FMI 2.0 layer's messages, and what an FMI 3.0 host called instead */
static const char *const RENAMED[][2] = {
    {"fmi2Instantiate", "fmi3InstantiateCoSimulation"}, {"fmi2SetupExperiment", "fmi3EnterInitializationMode"},
    {"fmi2EnterInitializationMode", "fmi3EnterInitializationMode"},
    {"fmi2ExitInitializationMode", "fmi3ExitInitializationMode"}, {"fmi2SetDebugLogging", "fmi3SetDebugLogging"},
    {"fmi2GetReal", "fmi3GetFloat64"}, {"fmi2SetReal", "fmi3SetFloat64"}, {"fmi2GetInteger", "fmi3GetInt32"},
    {"fmi2SetInteger", "fmi3SetInt32"}, {"fmi2GetBoolean", "fmi3GetBoolean"}, {"fmi2SetBoolean", "fmi3SetBoolean"},
    {"fmi2GetString", "fmi3GetString"}, {"fmi2SetString", "fmi3SetString"}, {"fmi2Reset", "fmi3Reset"},
    {"fmi2GetFMUstate", "fmi3GetFMUState"}, {"fmi2SetFMUstate", "fmi3SetFMUState"},
    {"fmi2SerializeFMUstate", "fmi3SerializeFMUState"}, {"fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState"},
    {"fmi2DoStep", "fmi3DoStep"}, {"fmi2Terminate", "fmi3Terminate"}, {"fmi2Error", "fmi3Error"},
    {"fmi2EnterEventMode", "fmi3EnterEventMode"}, {"fmi2NewDiscreteStates", "fmi3UpdateDiscreteStates"},
    {"fmi2EnterContinuousTimeMode", "fmi3EnterContinuousTimeMode"},
    {"fmi2CompletedIntegratorStep", "fmi3CompletedIntegratorStep"}, {"fmi2SetTime", "fmi3SetTime"},
    {"fmi2SetContinuousStates", "fmi3SetContinuousStates"}, {"fmi2GetContinuousStates", "fmi3GetContinuousStates"},
    {"fmi2GetDerivatives", "fmi3GetContinuousStateDerivatives"}, {"fmi2GetEventIndicators", "fmi3GetEventIndicators"},
    {"fmi2GetNominalsOfContinuousStates", "fmi3GetNominalsOfContinuousStates"},
    {"fmi2Discard", "fmi3Discard"}, {"fmi2Fatal", "fmi3Fatal"}, {"fmi2OK", "fmi3OK"},
};
#define N_RENAMED (sizeof RENAMED / sizeof RENAMED[0])

static int identifier_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

/* The FMI 2.0 layer's logger: its message comes already formatted, '%' doubled for printf-style hosts (see
 * mk_log); FMI 3.0's logMessage takes plain text. */
static void forward_log(fmi2ComponentEnvironment environment, fmi2String instanceName, fmi2Status status,
                        fmi2String category, fmi2String message, ...)
{
    mk3_instance *inst = (mk3_instance *)environment;
    char text[4 * MK_MESSAGE];
    size_t i = 0, j = 0, k, n;
    (void)instanceName;
    if (inst == NULL || inst->log == NULL || message == NULL) return;
    while (message[i] != '\0' && j + 1 < sizeof text) {
        if (message[i] == '%' && message[i + 1] == '%') {
            text[j++] = '%';
            i += 2;
        } else if (strncmp(message + i, "fmi2", 4) == 0 && (i == 0 || !identifier_char(message[i - 1]))) {
            for (n = 4; identifier_char(message[i + n]); n++) {}
            for (k = 0; k < N_RENAMED; k++)
                if (strlen(RENAMED[k][0]) == n && strncmp(message + i, RENAMED[k][0], n) == 0) break;
            if (k < N_RENAMED) {
                j += (size_t)snprintf(text + j, sizeof text - j, "%s", RENAMED[k][1]);
                if (j >= sizeof text) j = sizeof text - 1;
                i += n;
            } else {
                text[j++] = message[i++];
            }
        } else {
            text[j++] = message[i++];
        }
    }
    text[j] = '\0';
    inst->log(inst->environment, (fmi3Status)status, category, text);
}

/* A refusal of the FMI 3.0 layer itself, logged through the FMI 2.0 layer (same categories and rules). */
static fmi3Status refuse3(mk3_instance *inst, fmi3Status status, const char *fmt, ...)
{
    char message[2 * MK_MESSAGE];
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof message, fmt, args);
    va_end(args);
    mk_log((mk_instance *)inst->c2, (fmi2Status)status, "%s", message);
    return status;
}

#define INSTANCE3(i) mk3_instance *inst = (mk3_instance *)(i); if (inst == NULL) return fmi3Error

static fmi3Instance instantiate(fmi3String instanceName, fmi2Type type, fmi3String instantiationToken,
                                fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage)
{
    fmi2CallbackFunctions callbacks = {forward_log, calloc, free, NULL, NULL};
    mk3_instance *inst = (mk3_instance *)calloc(1, sizeof *inst);
    if (inst == NULL) return NULL;
    inst->environment = instanceEnvironment;
    inst->log = logMessage;
    callbacks.componentEnvironment = inst;
    inst->c2 = mk2_fmi2Instantiate(instanceName, type, instantiationToken, resourcePath, &callbacks,
                                   visible ? fmi2True : fmi2False, loggingOn ? fmi2True : fmi2False);
    if (inst->c2 == NULL) { /* logged by the FMI 2.0 layer */
        free(inst);
        return NULL;
    }
    return inst;
}

static void log_without_instance(fmi3InstanceEnvironment environment, fmi3LogMessageCallback logMessage,
                                 const char *message)
{
    if (logMessage != NULL) logMessage(environment, fmi3Error, "logStatusError", message);
}

/* --- common functions ------------------------------------------------------------------------------------------ */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2SetDebugLogging(inst->c2, loggingOn ? fmi2True : fmi2False, nCategories,
                                               (const fmi2String *)categories);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    return instantiate(instanceName, fmi2ModelExchange, instantiationToken, resourcePath, visible, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    /* no events, no early return, no intermediate update (hasEventMode, mightReturnEarlyFromDoStep and
     * providesIntermediateUpdate are false): the flags change nothing */
    (void)eventModeUsed; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    return instantiate(instanceName, fmi2CoSimulation, instantiationToken, resourcePath, visible, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    log_without_instance(instanceEnvironment, logMessage, MK_MODEL_NAME " offers no scheduled execution "
                         "(fmi3InstantiateScheduledExecution)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    mk3_instance *inst = (mk3_instance *)instance;
    if (inst == NULL) return;
    mk2_fmi2FreeInstance(inst->c2);
    free(inst);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    fmi2Status status;
    INSTANCE3(instance);
    status = mk2_fmi2SetupExperiment(inst->c2, toleranceDefined ? fmi2True : fmi2False, tolerance, startTime,
                                     stopTimeDefined ? fmi2True : fmi2False, stopTime);
    if (status > fmi2Warning) return (fmi3Status)status;
    return (fmi3Status)mk2_fmi2EnterInitializationMode(inst->c2);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2ExitInitializationMode(inst->c2);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    INSTANCE3(instance); /* Model Exchange; a Co-Simulation instance is refused (hasEventMode is false) */
    return (fmi3Status)mk2_fmi2EnterEventMode(inst->c2);
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2Terminate(inst->c2);
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2Reset(inst->c2);
}

/* --- values ------------------------------------------------------------------------------------------------------ */

static fmi3Status check_count(mk3_instance *inst, const char *what, size_t nValueReferences, size_t nValues)
{
    if (nValues != nValueReferences) /* every variable here is a scalar */
        return refuse3(inst, fmi3Error, "%s: %lu values for %lu value references (every variable is a scalar)",
                       what, (unsigned long)nValues, (unsigned long)nValueReferences);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues)
{
    size_t k;
    fmi2Status status = fmi2OK, s;
    INSTANCE3(instance);
    if (check_count(inst, "fmi3GetFloat64", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    for (k = 0; k < nValueReferences; k++)
        if (valueReferences[k] >= MK3_VR_TIME) break;
    if (k == nValueReferences) /* none of FMI 3.0's own variables among them: one call */
        return (fmi3Status)mk2_fmi2GetReal(inst->c2, valueReferences, nValueReferences, values);
    for (k = 0; k < nValueReferences; k++) {
        fmi3ValueReference vr = valueReferences[k];
        if (vr == MK3_VR_TIME) {
            s = mk2_fmi2GetRealStatus(inst->c2, fmi2LastSuccessfulTime, &values[k]); /* the state's time */
        } else if (vr >= MK3_VR_EVENT_INDICATOR(0) && vr < MK3_VR_EVENT_INDICATOR(MK_ME_NZ)) {
            fmi2Real z[MK_ME_NZ > 0 ? MK_ME_NZ : 1];
            s = mk2_fmi2GetEventIndicators(inst->c2, z, MK_ME_NZ);
            values[k] = z[vr - MK3_VR_EVENT_INDICATOR(0)];
        } else {
            s = mk2_fmi2GetReal(inst->c2, &valueReferences[k], 1, &values[k]);
        }
        if (s > fmi2Warning) return (fmi3Status)s;
        if (s > status) status = s;
    }
    return (fmi3Status)status;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues)
{
    size_t k;
    INSTANCE3(instance);
    if (check_count(inst, "fmi3SetFloat64", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        if (valueReferences[k] == MK3_VR_TIME)
            return refuse3(inst, fmi3Error, "fmi3SetFloat64: time (value reference %u) is the independent variable "
                           "and cannot be set (Model Exchange: fmi3SetTime)", (unsigned)MK3_VR_TIME);
        if (valueReferences[k] > MK3_VR_TIME)
            return refuse3(inst, fmi3Error, "fmi3SetFloat64: value reference %u is an event indicator and cannot "
                           "be set", (unsigned)valueReferences[k]);
    }
    return (fmi3Status)mk2_fmi2SetReal(inst->c2, valueReferences, nValueReferences, values);
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues)
{
    size_t k;
    fmi2Status status = fmi2OK, s;
    fmi2Integer value;
    INSTANCE3(instance);
    if (check_count(inst, "fmi3GetInt32", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        s = mk2_fmi2GetInteger(inst->c2, &valueReferences[k], 1, &value);
        if (s > fmi2Warning) return (fmi3Status)s;
        if (s > status) status = s;
        values[k] = (fmi3Int32)value;
    }
    return (fmi3Status)status;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues)
{
    size_t k;
    fmi2Integer value;
    INSTANCE3(instance);
    if (check_count(inst, "fmi3SetInt32", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        value = (fmi2Integer)values[k];
        if (mk2_fmi2SetInteger(inst->c2, &valueReferences[k], 1, &value) != fmi2OK) return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues)
{
    size_t k;
    fmi2Status status = fmi2OK, s;
    fmi2Boolean value;
    INSTANCE3(instance);
    if (check_count(inst, "fmi3GetBoolean", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        s = mk2_fmi2GetBoolean(inst->c2, &valueReferences[k], 1, &value);
        if (s > fmi2Warning) return (fmi3Status)s;
        if (s > status) status = s;
        values[k] = value ? fmi3True : fmi3False;
    }
    return (fmi3Status)status;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues)
{
    size_t k;
    fmi2Boolean value;
    INSTANCE3(instance);
    if (check_count(inst, "fmi3SetBoolean", nValueReferences, nValues) != fmi3OK) return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        value = values[k] ? fmi2True : fmi2False;
        if (mk2_fmi2SetBoolean(inst->c2, &valueReferences[k], 1, &value) != fmi2OK) return fmi3Error;
    }
    return fmi3OK;
}

/* The types this FMU has no variables of. */
#define NO_VARIABLES_OF(function, arguments)                                                                     \
    fmi3Status function arguments                                                                                \
    {                                                                                                            \
        INSTANCE3(instance);                                                                                     \
        if (nValueReferences == 0) return fmi3OK;                                                                \
        return refuse3(inst, fmi3Error, "%s: %s has no variables of this type (value reference %u)", #function, \
                       MK_MODEL_NAME, (unsigned)valueReferences[0]);                                             \
    }
#define GET_ARGS(type) (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                        type values[], size_t nValues)
#define SET_ARGS(type) (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                        const type values[], size_t nValues)

NO_VARIABLES_OF(fmi3GetFloat32, GET_ARGS(fmi3Float32))
NO_VARIABLES_OF(fmi3GetInt8, GET_ARGS(fmi3Int8))
NO_VARIABLES_OF(fmi3GetUInt8, GET_ARGS(fmi3UInt8))
NO_VARIABLES_OF(fmi3GetInt16, GET_ARGS(fmi3Int16))
NO_VARIABLES_OF(fmi3GetUInt16, GET_ARGS(fmi3UInt16))
NO_VARIABLES_OF(fmi3GetUInt32, GET_ARGS(fmi3UInt32))
NO_VARIABLES_OF(fmi3GetInt64, GET_ARGS(fmi3Int64))
NO_VARIABLES_OF(fmi3GetUInt64, GET_ARGS(fmi3UInt64))
NO_VARIABLES_OF(fmi3GetString, GET_ARGS(fmi3String))
NO_VARIABLES_OF(fmi3SetFloat32, SET_ARGS(fmi3Float32))
NO_VARIABLES_OF(fmi3SetInt8, SET_ARGS(fmi3Int8))
NO_VARIABLES_OF(fmi3SetUInt8, SET_ARGS(fmi3UInt8))
NO_VARIABLES_OF(fmi3SetInt16, SET_ARGS(fmi3Int16))
NO_VARIABLES_OF(fmi3SetUInt16, SET_ARGS(fmi3UInt16))
NO_VARIABLES_OF(fmi3SetUInt32, SET_ARGS(fmi3UInt32))
NO_VARIABLES_OF(fmi3SetInt64, SET_ARGS(fmi3Int64))
NO_VARIABLES_OF(fmi3SetUInt64, SET_ARGS(fmi3UInt64))
NO_VARIABLES_OF(fmi3SetString, SET_ARGS(fmi3String))
NO_VARIABLES_OF(fmi3GetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, size_t valueSizes[], fmi3Binary values[], size_t nValues))
NO_VARIABLES_OF(fmi3SetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const size_t valueSizes[], const fmi3Binary values[],
                                size_t nValues))
NO_VARIABLES_OF(fmi3GetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Clock values[]))
NO_VARIABLES_OF(fmi3SetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Clock values[]))
NO_VARIABLES_OF(fmi3GetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                         size_t nValueReferences, fmi3Float64 intervals[],
                                         fmi3IntervalQualifier qualifiers[]))
NO_VARIABLES_OF(fmi3GetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                          size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                          fmi3IntervalQualifier qualifiers[]))
NO_VARIABLES_OF(fmi3GetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences, fmi3Float64 shifts[]))
NO_VARIABLES_OF(fmi3GetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                       size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]))
NO_VARIABLES_OF(fmi3SetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                         size_t nValueReferences, const fmi3Float64 intervals[]))
NO_VARIABLES_OF(fmi3SetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                          size_t nValueReferences, const fmi3UInt64 counters[],
                                          const fmi3UInt64 resolutions[]))
NO_VARIABLES_OF(fmi3SetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences, const fmi3Float64 shifts[]))
NO_VARIABLES_OF(fmi3SetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                       size_t nValueReferences, const fmi3UInt64 counters[],
                                       const fmi3UInt64 resolutions[]))

/* What this FMU does not provide (its modelDescription.xml says so). */
#define NOT_PROVIDED(function, arguments, why)                                                                   \
    fmi3Status function arguments                                                                                \
    {                                                                                                            \
        INSTANCE3(instance);                                                                                     \
        return refuse3(inst, fmi3Error, "%s: not provided (%s)", #function, why);                               \
    }

NOT_PROVIDED(fmi3GetNumberOfVariableDependencies, (fmi3Instance instance, fmi3ValueReference valueReference,
                                                   size_t *nDependencies), "the dependencies are in modelDescription.xml")
NOT_PROVIDED(fmi3GetVariableDependencies, (fmi3Instance instance, fmi3ValueReference dependent,
                                           size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                           size_t elementIndicesOfIndependents[],
                                           fmi3DependencyKind dependencyKinds[], size_t nDependencies),
             "the dependencies are in modelDescription.xml")
NOT_PROVIDED(fmi3GetDirectionalDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[],
                                            size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                            const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                            size_t nSensitivity), "providesDirectionalDerivatives is false")
NOT_PROVIDED(fmi3GetAdjointDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity), "providesAdjointDerivatives is false")
NOT_PROVIDED(fmi3EnterConfigurationMode, (fmi3Instance instance), "no structural parameters")
NOT_PROVIDED(fmi3ExitConfigurationMode, (fmi3Instance instance), "no structural parameters")
NOT_PROVIDED(fmi3EvaluateDiscreteStates, (fmi3Instance instance), "providesEvaluateDiscreteStates is false")
NOT_PROVIDED(fmi3EnterStepMode, (fmi3Instance instance), "no event mode: the instance is in step mode after "
             "fmi3ExitInitializationMode")
NOT_PROVIDED(fmi3GetOutputDerivatives, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                        size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                        size_t nValues), "maxOutputDerivativeOrder is 0")
NOT_PROVIDED(fmi3ActivateModelPartition, (fmi3Instance instance, fmi3ValueReference clockReference,
                                          fmi3Float64 activationTime), "no scheduled execution")
/* --- Model Exchange: the FMI 2.0 functions ------------------------------------------------------------------- */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    fmi2EventInfo info = {fmi2False, fmi2False, fmi2False, fmi2False, fmi2False, 0.0};
    fmi2Status status;
    INSTANCE3(instance);
    status = mk2_fmi2NewDiscreteStates(inst->c2, &info);
    if (discreteStatesNeedUpdate != NULL) *discreteStatesNeedUpdate = info.newDiscreteStatesNeeded != fmi2False;
    if (terminateSimulation != NULL) *terminateSimulation = info.terminateSimulation != fmi2False;
    if (nominalsOfContinuousStatesChanged != NULL)
        *nominalsOfContinuousStatesChanged = info.nominalsOfContinuousStatesChanged != fmi2False;
    if (valuesOfContinuousStatesChanged != NULL)
        *valuesOfContinuousStatesChanged = info.valuesOfContinuousStatesChanged != fmi2False;
    if (nextEventTimeDefined != NULL) *nextEventTimeDefined = info.nextEventTimeDefined != fmi2False;
    if (nextEventTime != NULL) *nextEventTime = info.nextEventTime;
    return (fmi3Status)status;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2EnterContinuousTimeMode(inst->c2);
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    fmi2Boolean event = fmi2False, terminate = fmi2False;
    fmi2Status status;
    INSTANCE3(instance);
    status = mk2_fmi2CompletedIntegratorStep(inst->c2, noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False,
                                             &event, &terminate);
    if (enterEventMode != NULL) *enterEventMode = event != fmi2False;
    if (terminateSimulation != NULL) *terminateSimulation = terminate != fmi2False;
    return (fmi3Status)status;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2SetTime(inst->c2, time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2SetContinuousStates(inst->c2, continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2GetDerivatives(inst->c2, derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2GetEventIndicators(inst->c2, eventIndicators, nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2GetContinuousStates(inst->c2, continuousStates, nContinuousStates);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2GetNominalsOfContinuousStates(inst->c2, nominals, nContinuousStates);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    INSTANCE3(instance);
    if (nEventIndicators == NULL) return refuse3(inst, fmi3Error, "fmi3GetNumberOfEventIndicators: no pointer given");
    *nEventIndicators = MK_ME_NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    INSTANCE3(instance);
    if (nContinuousStates == NULL)
        return refuse3(inst, fmi3Error, "fmi3GetNumberOfContinuousStates: no pointer given");
    *nContinuousStates = MK_ME_NX;
    return fmi3OK;
}

/* --- FMU state -------------------------------------------------------------------------------------------------- */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2GetFMUstate(inst->c2, (fmi2FMUstate *)FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2SetFMUstate(inst->c2, (fmi2FMUstate)FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2FreeFMUstate(inst->c2, (fmi2FMUstate *)FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2SerializedFMUstateSize(inst->c2, (fmi2FMUstate)FMUState, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2SerializeFMUstate(inst->c2, (fmi2FMUstate)FMUState, (fmi2Byte *)serializedState,
                                                 size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    INSTANCE3(instance);
    return (fmi3Status)mk2_fmi2DeSerializeFMUstate(inst->c2, (const fmi2Byte *)serializedState, size,
                                                   (fmi2FMUstate *)FMUState);
}

/* --- stepping --------------------------------------------------------------------------------------------------- */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    fmi2Status status;
    fmi2Real time;
    INSTANCE3(instance);
    if (eventHandlingNeeded == NULL || terminateSimulation == NULL || earlyReturn == NULL ||
        lastSuccessfulTime == NULL)
        return refuse3(inst, fmi3Error, "fmi3DoStep: an output argument is NULL");
    *eventHandlingNeeded = fmi3False;
    *earlyReturn = fmi3False;
    status = mk2_fmi2DoStep(inst->c2, currentCommunicationPoint, communicationStepSize,
                            noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False);
    /* a refused step ends the run: the host must not retry it (model-spec section 7c) */
    *terminateSimulation = status > fmi2Warning ? fmi3True : fmi3False;
    if (mk2_fmi2GetRealStatus(inst->c2, fmi2LastSuccessfulTime, &time) != fmi2OK)
        time = currentCommunicationPoint;
    *lastSuccessfulTime = time;
    return (fmi3Status)status;
}
