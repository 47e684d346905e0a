/* A minimal FMI 2.0 Model Exchange host in C: the host integrates the FMU's states itself.
 *
 * Usage: fmi2_me_host FMU_DIR GUID STOP STEP SUBSTEPS NX OUT_VR [VR=VALUE ...]
 *   FMU_DIR   the unzipped FMU (binaries/<platform>/<model>.so|.dll, resources/)
 *   GUID      the guid attribute of its modelDescription.xml
 *   STEP      the output interval [s]; each is integrated in SUBSTEPS classical Runge-Kutta steps
 *   NX        the number of continuous states (numberOfContinuousStates of its modelDescription.xml)
 *   OUT_VR    value reference of the Real output to print after every output interval
 *   VR=VALUE  Real start values (parameters or inputs) to set before initialization
 * Prints "time value" lines on stdout and the FMU's log messages on stderr; exits 0 only if every call
 * returned fmi2OK and the run reached STOP.
 *
 * Fixed steps and no root finding, on purpose: the same arithmetic on every platform, so that the ARM
 * binary under qemu-user (tests/test_platforms.py) and the Windows one under Wine can be held to the
 * Linux binary's numbers. The event indicators are not searched for crossings; a step whose
 * fmi2CompletedIntegratorStep asks for event mode gets it (fmi2EnterEventMode, fmi2NewDiscreteStates
 * until no new iteration is needed, back to continuous time).
 *
 * Build as fmi2_host.c (see there): gcc -I <fmpy>/c-code -o fmi2_me_host fmi2_me_host.c -ldl
 */
#include "fmi2_host_common.h" /* the FMI 2.0 hosts' platform folder, loader, logger and CHECK */

#define MAX_STATES 64

/* The functions of the FMU this host calls. */
typedef struct {
    fmi2SetTimeTYPE *set_time;
    fmi2SetContinuousStatesTYPE *set_states;
    fmi2GetDerivativesTYPE *get_derivatives;
    fmi2EnterEventModeTYPE *enter_event_mode;
    fmi2NewDiscreteStatesTYPE *new_discrete_states;
    fmi2EnterContinuousTimeModeTYPE *enter_continuous_time_mode;
} Api;

/* The derivatives at (t, x). */
static int derivatives(const Api *api, fmi2Component fmu, double t, const double *x, size_t n, double *dx)
{
    CHECK(api->set_time(fmu, t));
    CHECK(api->set_states(fmu, x, n));
    CHECK(api->get_derivatives(fmu, dx, n));
    return 0;
}

/* One classical Runge-Kutta step of h from (t, x), x updated in place. */
static int rk4_step(const Api *api, fmi2Component fmu, double t, double h, double *x, size_t n)
{
    double k1[MAX_STATES], k2[MAX_STATES], k3[MAX_STATES], k4[MAX_STATES], y[MAX_STATES];
    size_t i;
    if (derivatives(api, fmu, t, x, n, k1)) return 1;
    for (i = 0; i < n; i++) y[i] = x[i] + 0.5 * h * k1[i];
    if (derivatives(api, fmu, t + 0.5 * h, y, n, k2)) return 1;
    for (i = 0; i < n; i++) y[i] = x[i] + 0.5 * h * k2[i];
    if (derivatives(api, fmu, t + 0.5 * h, y, n, k3)) return 1;
    for (i = 0; i < n; i++) y[i] = x[i] + h * k3[i];
    if (derivatives(api, fmu, t + h, y, n, k4)) return 1;
    for (i = 0; i < n; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    CHECK(api->set_time(fmu, t + h));
    CHECK(api->set_states(fmu, x, n));
    return 0;
}

/* Event mode until the FMU needs no new iteration, then back to continuous time. */
static int handle_event(const Api *api, fmi2Component fmu)
{
    fmi2EventInfo info;
    CHECK(api->enter_event_mode(fmu));
    do {
        CHECK(api->new_discrete_states(fmu, &info));
        if (info.terminateSimulation) {
            fprintf(stderr, "the FMU asked to terminate\n");
            return 1;
        }
    } while (info.newDiscreteStatesNeeded);
    CHECK(api->enter_continuous_time_mode(fmu));
    return 0;
}

int main(int argc, char *argv[])
{
    char real_dir[PATH_MAX];
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    double stop, step, time = 0.0, value, x[MAX_STATES];
    long k, steps, substeps, j;
    size_t n;
    fmi2ValueReference out_vr;
    fmi2Boolean enter_event, terminate_now;
    fmi2EventInfo info;
    void *library;
    fmi2Component fmu;
    Api api;
    int usage_error;

    if (argc < 8) {
        fprintf(stderr, "usage: %s FMU_DIR GUID STOP STEP SUBSTEPS NX OUT_VR [VR=VALUE ...]\n", argv[0]);
        return 2;
    }
    stop = atof(argv[3]);
    step = atof(argv[4]);
    substeps = atol(argv[5]);
    n = (size_t)strtoul(argv[6], NULL, 10);
    out_vr = (fmi2ValueReference)strtoul(argv[7], NULL, 10);
    if (substeps < 1 || step <= 0.0 || n > MAX_STATES) {
        fprintf(stderr, "STEP must be positive, SUBSTEPS at least 1 and NX at most %d\n", MAX_STATES);
        return 2;
    }
    library = load_fmu_binary(argv[1], real_dir);
    if (library == NULL) return 2;
    fmi2GetRealTYPE *get_real = (fmi2GetRealTYPE *)symbol(library, "fmi2GetReal");
    fmi2GetContinuousStatesTYPE *get_states = (fmi2GetContinuousStatesTYPE *)symbol(library, "fmi2GetContinuousStates");
    fmi2CompletedIntegratorStepTYPE *completed =
        (fmi2CompletedIntegratorStepTYPE *)symbol(library, "fmi2CompletedIntegratorStep");
    fmi2TerminateTYPE *terminate = (fmi2TerminateTYPE *)symbol(library, "fmi2Terminate");
    fmi2FreeInstanceTYPE *free_instance = (fmi2FreeInstanceTYPE *)symbol(library, "fmi2FreeInstance");
    api.set_time = (fmi2SetTimeTYPE *)symbol(library, "fmi2SetTime");
    api.set_states = (fmi2SetContinuousStatesTYPE *)symbol(library, "fmi2SetContinuousStates");
    api.get_derivatives = (fmi2GetDerivativesTYPE *)symbol(library, "fmi2GetDerivatives");
    api.enter_event_mode = (fmi2EnterEventModeTYPE *)symbol(library, "fmi2EnterEventMode");
    api.new_discrete_states = (fmi2NewDiscreteStatesTYPE *)symbol(library, "fmi2NewDiscreteStates");
    api.enter_continuous_time_mode =
        (fmi2EnterContinuousTimeModeTYPE *)symbol(library, "fmi2EnterContinuousTimeMode");

    fmu = start_fmu(library, real_dir, argv[2], fmi2ModelExchange, &callbacks, stop, 8, argc, argv, &usage_error);
    if (fmu == NULL) return usage_error ? 2 : 1;
    /* the initial event iteration, then continuous time */
    do {
        CHECK(api.new_discrete_states(fmu, &info));
    } while (info.newDiscreteStatesNeeded);
    CHECK(api.enter_continuous_time_mode(fmu));
    if (n > 0) CHECK(get_states(fmu, x, n));
    CHECK(get_real(fmu, &out_vr, 1, &value));
    printf("%.17g %.17g\n", time, value);
    steps = (long)(stop / step + 0.5);
    for (k = 0; k < steps; k++) {
        for (j = 0; j < substeps; j++) {
            double t = k * step + j * (step / substeps);
            if (n > 0 && rk4_step(&api, fmu, t, step / substeps, x, n)) return 1;
            if (n == 0) CHECK(api.set_time(fmu, t + step / substeps));
            CHECK(completed(fmu, fmi2True, &enter_event, &terminate_now));
            if (terminate_now) {
                fprintf(stderr, "the FMU asked to terminate\n");
                return 1;
            }
            if (enter_event && handle_event(&api, fmu)) return 1;
        }
        time = (k + 1) * step;
        CHECK(get_real(fmu, &out_vr, 1, &value));
        printf("%.17g %.17g\n", time, value);
    }
    CHECK(terminate(fmu));
    free_instance(fmu);
    return 0; /* the library stays loaded until exit, as in fmpy */
}
