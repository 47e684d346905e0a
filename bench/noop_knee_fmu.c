/* bench/bench_native_fmu.py's floor: the knee FMU's interface and FMI wrapper with a model that does nothing
 * (the state stays, the outputs are copied from it). fmpy's per-step cost with this FMU is what any knee FMU
 * pays at least. */
#include <math.h>
#include <stddef.h>

#include "mk_fmu.h"

int mk_model_start(mk_data *d, char *msg, size_t size)
{
    (void)msg;
    (void)size;
    d->s.ny = 2;
    d->s.y[0] = d->v[VR_X0];
    d->s.y[1] = 0.0;
    return 0;
}

int mk_model_step(mk_data *d, double dt, char *msg, size_t size)
{
    (void)msg;
    (void)size;
    d->s.time += dt;
    return 0;
}

int mk_model_outputs(mk_data *d, char *msg, size_t size)
{
    int vr;
    (void)msg;
    (void)size;
    for (vr = 0; vr < NV; vr++)
        if (mk_variables[vr].causality == MK_OUTPUT) d->v[vr] = 0.0;
    d->v[VR_X] = d->s.y[0];
    d->v[VR_V] = d->s.y[1];
    d->v[VR_Pe] = d->v[VR_pe_cmd];
    d->v[VR_Pf] = d->v[VR_pf_cmd];
    return 0;
}

void mk_model_fallback_outputs(mk_data *d) { (void)d; }
