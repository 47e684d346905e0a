/* TEMPORARY PLACEHOLDER until the compiled core (mkctl/native, branch core) lands: no physics here, only enough
 * to exercise the FMI wrapper, the build, the packing and validation. The tests that compare with the pythonfmu
 * FMUs fail against it, as they must. */
#include <math.h>
#include <stdio.h>

#include "mk_core_api.h"

const double MK_DEFAULT_ALPHA = 1.0471975511965976;
const double MK_ALPHA_STOP_LOW = 0.08726646259971647;
const double MK_ALPHA_STOP_HIGH = 1.3089969389957472;

double mk_core_derived_turns(double b, double L0, double D0) { return sqrt(b * b - L0 * L0) / (3.141592653589793 * D0); }
double mk_core_X_from_alpha(const mk_params *p, double alpha) { (void)alpha; return 0.5 * (p->Lo + p->Lu); }
int mk_core_knee_posture(const mk_params *p, double X, double out[4])
{
    (void)p; (void)X;
    out[0] = out[1] = out[2] = out[3] = 0.0;
    return 0;
}
int mk_core_knee_outputs(const mk_params *p, double X, double V, double Pe, double Pf, double out[MK_KNEE_N_OUTPUTS],
                         char *msg, size_t size)
{
    int k;
    (void)p;
    for (k = 0; k < MK_KNEE_N_OUTPUTS; k++) out[k] = 0.0;
    out[0] = X; out[1] = V; out[8] = Pe; out[9] = Pf;
    if (!isfinite(Pe) || !isfinite(Pf)) {
        snprintf(msg, size, "pressure is not a finite number (NaN or infinite)");
        return 1;
    }
    return 0;
}
int mk_core_knee_step(const mk_params *p, const double stops[2], double pe_cmd, double pf_cmd, double *y, int ny,
                      double dt, double *h, char *msg, size_t size)
{
    (void)p; (void)stops; (void)pe_cmd; (void)pf_cmd; (void)y; (void)ny; (void)dt; (void)h; (void)msg; (void)size;
    return 0;
}
double mk_core_lagged_pressure(double P, double P_cmd, double tau, double dt)
{
    return tau <= 0 ? P_cmd : P_cmd + (P - P_cmd) * exp(-dt / tau);
}
int mk_core_actuator_tension(const mk_params *p, double L, double P, double Ldot, double *f, char *msg, size_t size)
{
    (void)Ldot;
    if (!(0 < L && L < p->b)) {
        snprintf(msg, size, "actuator length L = %g m is outside the model's domain 0 < L < b = %g m", L, p->b);
        return 1;
    }
    *f = 0.0 * P;
    return 0;
}
