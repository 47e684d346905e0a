/* What the FMUs' model parts use of the compiled core (mkctl/native/core_template.c + generated equations, one
 * compilation unit written by mkctl/native/fmu.py as mkctl_core.c, with the FMUs' own generated additions:
 * hip height from alpha, the posture at X, the fault messages and the integrator settings of KneeSimulator).
 * Every int function returns 0 on success or a fault code with details in *fault. */
#ifndef MK_CORE_API_H
#define MK_CORE_API_H

#include <stddef.h>

/* the core's mk_fault, same layout (core_template.c) */
typedef struct {
    int code;
    int check;
    long sample;
    double value;
    double low;
    double high;
} mk_fault;

#define MK_CORE_STAGES 28 /* 7 stages x 4 states: the integrator's first-same-as-last storage */

/* the core (parameter vector p: every field of mkctl.physics.params.Params in declaration order) */
int mk_knee_step(const double *p, const double *stops, double *y, double dt, double pe_cmd, double pf_cmd,
                 double rtol, const double *atol, double *h_hint, double *k, int *k1_valid, double *k_pe,
                 double *k_pf, mk_fault *fault);
int mk_knee_outputs(const double *p, const double *y, double pe_cmd, double pf_cmd, double *out, mk_fault *fault);
int mk_knee_nstate(const double *p);
int mk_pressure_is_state(const double *p); /* 1 when an effect with pressure dynamics is on (a lag) */
int mk_command_delay(const double *p, double *out, mk_fault *fault); /* a dead time [s], 0 without */
int mk_stop_positions(const double *p, double *out, mk_fault *fault);
int mk_actuator_tension(const double *p, double L, double P, double Ldot, double *f, mk_fault *fault);
int mk_actuator_lagged_pressure(const double *p, double P, double P_cmd, double dt, double *out, mk_fault *fault);

/* generated for the FMUs from mkctl's equations (mkctl/native/fmu.py) */
int mk_fmu_X_from_alpha(const double *p, double alpha, double *out, mk_fault *fault); /* knee.X_from_alpha */
int mk_fmu_posture(const double *p, double X, double *out, mk_fault *fault); /* alpha, beta, Le, Lf at X */
extern const double MK_FMU_DEFAULT_ALPHA;   /* the default posture [rad] (mkctl.physics.stability) */
extern const double MK_FMU_KNEE_RTOL;       /* KneeSimulator's tolerances and first step */
extern const double MK_FMU_KNEE_ATOL[4];
extern const double MK_FMU_KNEE_H0;

/* the fault as mkctl's Python would say it (the library's message, with the failing value) */
void mk_fault_message(const mk_fault *fault, char *msg, size_t size);
/* a domain fault with a message template of mk_fmu_fault_templates' form (a mechanism FMU's own checks) */
void mk_fault_format(const char *template_text, const mk_fault *fault, char *msg, size_t size);
/* n = sqrt(b^2 - L0^2) / (pi D0), mkctl.physics.params.derived_turns */
double mk_fmu_derived_turns(double b, double L0, double D0);

#endif
