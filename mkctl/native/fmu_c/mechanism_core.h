/* What a mechanism FMU's parts (mechanism_fmu.c, mechanism_me.c) use of its generated mechanism_core.c
 * (mkctl/native/mechanism_fmu.py). Every int function returns 0, or a fault code with details in *fault. */
#ifndef MECHANISM_CORE_H
#define MECHANISM_CORE_H

#include <stddef.h>

#include "mk_core_api.h"

extern const int mk_mech_muscles;            /* one or two */
extern const int mk_mech_command_vr[2];      /* the pressure inputs (one muscle: the same twice) */
extern const int mk_mech_q0_vr;
extern const int mk_mech_output_vr[];        /* q, qdot, L..., f..., P..., a1, a2, stable */
extern const int mk_mech_nout;               /* the outputs after q, qdot (mk_mech_outputs) */
extern const int mk_mech_nz;
extern const char *const mk_mech_fault_templates[];
extern const int mk_mech_fault_count;
extern const double MK_MECH_RTOL;            /* simulate_mechanism's relative tolerance */
extern const double MK_MECH_H0;              /* and its first step [s] */
extern const char MK_MECH_STOPS_FORMAT[];    /* Mechanism.stop_positions' message: %g low, %g high */

int mk_mech_nstate(const double *p);
int mk_mech_stops(const double *p, double *out, mk_fault *fault);
int mk_mech_check_parameters(const double *p, char *msg, size_t size);
int mk_mech_step(const double *p, const double *stops, double *y, double dt, double c1, double c2, double rtol,
                 double *h_hint, double *k, int *k1_valid, double *k_c1, double *k_c2, mk_fault *fault);
int mk_mech_rhs(const double *p, const double *stops, const double *y, double c1, double c2, double *dy,
                mk_fault *fault);
int mk_mech_event_indicators(const double *p, const double *stops, const double *y, double c1, double c2,
                             double *out, mk_fault *fault);
int mk_mech_outputs(const double *p, const double *y, double c1, double c2, double *out, mk_fault *fault);

/* in mechanism_fmu.c: the fault in the library's words (the mechanism's checks, else the core's) */
void mk_mech_fault_message(const mk_fault *fault, char *msg, size_t size);
/* the muscles' commands in force (pressures or, for the mechanism alone, tensions; one muscle: twice) */
void mk_mech_seen_commands(const mk_data *d, double *c);
/* the parameter vector and the end stops of the present parameters, the own parameters checked */
int mk_mech_setup(const mk_data *d, double *p, double *stops, char *msg, size_t size);

#endif
