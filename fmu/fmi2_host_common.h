/* What the FMI 2.0 hosts share (fmi2_host.c: Co-Simulation; fmi2_me_host.c: Model Exchange): the binary
 * folder of this platform, finding and loading the binary (host_common.h), the logger and CHECK. */
#ifndef FMI2_HOST_COMMON_H
#define FMI2_HOST_COMMON_H
#include <stdarg.h>
#include "fmi2Functions.h"

#if defined(_WIN32)
#define BINARY_FOLDER "win64"
#elif defined(__APPLE__)
#define BINARY_FOLDER "darwin64"
#elif defined(__aarch64__) /* FMI 2.0 has no name for ARM Linux: FMI 3.0's, for the compiled sources */
#define BINARY_FOLDER "aarch64-linux"
#else
#define BINARY_FOLDER "linux64"
#endif
#include "host_common.h" /* finding and loading the binary, on Linux and Windows */

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list args;
    (void)env;
    fprintf(stderr, "[%s] status %d %s: ", instance, (int)status, category);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

#define CHECK(call)                                                            \
    do {                                                                       \
        fmi2Status status_ = (call);                                           \
        if (status_ != fmi2OK) {                                               \
            fprintf(stderr, "%s returned status %d\n", #call, (int)status_);   \
            return 1;                                                          \
        }                                                                      \
    } while (0)

/* The first calls of every run, the same in both hosts: instantiate the FMU as `kind` (fmi2CoSimulation or
 * fmi2ModelExchange) with its resources folder, set up the experiment up to `stop`, enter initialization
 * mode, set the Real start values argv[first..argc) given as VR=VALUE, and leave initialization mode.
 * Returns the instance, or NULL after saying on stderr what failed (*usage_error set for a bad VR=VALUE). */
static fmi2Component start_fmu(void *library, const char *real_dir, fmi2String guid, fmi2Type kind,
                               const fmi2CallbackFunctions *callbacks, double stop, int first, int argc,
                               char *argv[], int *usage_error)
{
    char resources[PATH_MAX + 64];
    fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)symbol(library, "fmi2Instantiate");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)symbol(library, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter =
        (fmi2EnterInitializationModeTYPE *)symbol(library, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave =
        (fmi2ExitInitializationModeTYPE *)symbol(library, "fmi2ExitInitializationMode");
    fmi2SetRealTYPE *set_real = (fmi2SetRealTYPE *)symbol(library, "fmi2SetReal");
    fmi2Component fmu;
    fmi2Status status;
    int i;

    *usage_error = 0;
    snprintf(resources, sizeof resources, "file://%s/resources", real_dir);
    fmu = instantiate("host", kind, guid, resources, callbacks, fmi2False, fmi2True);
    if (fmu == NULL) {
        fprintf(stderr, "fmi2Instantiate failed\n");
        return NULL;
    }
    status = setup(fmu, fmi2False, 0.0, 0.0, fmi2True, stop);
    if (status == fmi2OK) status = enter(fmu);
    for (i = first; status == fmi2OK && i < argc; i++) {
        fmi2ValueReference vr;
        double value;
        if (sscanf(argv[i], "%u=%lf", &vr, &value) != 2) {
            fprintf(stderr, "bad start value %s (want VR=VALUE)\n", argv[i]);
            *usage_error = 1;
            return NULL;
        }
        status = set_real(fmu, &vr, 1, &value);
    }
    if (status == fmi2OK) status = leave(fmu);
    if (status != fmi2OK) {
        fprintf(stderr, "starting the FMU returned status %d\n", (int)status);
        return NULL;
    }
    return fmu;
}

#endif
