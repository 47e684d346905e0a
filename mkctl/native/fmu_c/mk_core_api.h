/* What the FMUs' model parts need from the compiled core (mkctl/native): one adapter over it, mk_core_api.c.
 * Every function returns 0 on success, or nonzero with a one-line message (mkctl's wording) in msg. */
#ifndef MK_CORE_API_H
#define MK_CORE_API_H

#include <stddef.h>

typedef struct {
    double b, n, L0, D0, C1, C2, t0, m, L1, L2, L5, L6, Lo, Lu, Lec, Lfc, r, g, c, Fc, vs, tau;
    int model;
} mk_params;

#define MK_KNEE_N_OUTPUTS 13 /* X, V, alpha, beta, Le, Lf, fe, ff, Pe, Pf, F, a1, a2 */

extern const double MK_DEFAULT_ALPHA;   /* the default posture, alpha = 60 deg [rad] */
extern const double MK_ALPHA_STOP_LOW;  /* end stops [rad] */
extern const double MK_ALPHA_STOP_HIGH;

double mk_core_derived_turns(double b, double L0, double D0);
double mk_core_X_from_alpha(const mk_params *p, double alpha);
/* alpha, beta, Le, Lf at hip height X (fallback outputs) */
int mk_core_knee_posture(const mk_params *p, double X, double out[4]);
int mk_core_knee_outputs(const mk_params *p, double X, double V, double Pe, double Pf, double out[MK_KNEE_N_OUTPUTS],
                         char *msg, size_t size);
/* integrate the knee over dt, commands held, end stops at stops[0..1]; y and *h updated only on success */
int mk_core_knee_step(const mk_params *p, const double stops[2], double pe_cmd, double pf_cmd, double *y, int ny,
                      double dt, double *h, char *msg, size_t size);
double mk_core_lagged_pressure(double P, double P_cmd, double tau, double dt);
int mk_core_actuator_tension(const mk_params *p, double L, double P, double Ldot, double *f, char *msg, size_t size);

#endif
