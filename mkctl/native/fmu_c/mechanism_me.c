/* A mechanism's Model Exchange part (model-spec sections 7c, 7d): derivatives and event indicators of the states
 * q, qdot and one pressure-lag state per muscle (inert, derivative 0, without a lag), from the generated
 * mechanism_core.c (mechanism.mechanism_derivatives and the switching functions found in it). With a dead time
 * both see the commands in force since the last event (mk_seen_commands). */
#include <stdio.h>

#include "mk_fmu.h"
#include "mk_core_api.h"
#include "mk_run.h"
#include "mechanism_core.h"

int mk_model_derivatives(const mk_data *d, double *dx, char *msg, size_t size)
{
    double p[MK_NPARAM], stops[2], dy[MK_MAX_STATES] = {0.0, 0.0, 0.0, 0.0}, seen[2];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    int i;
    mk_mech_seen_commands(d, seen);
    if (mk_mech_setup(d, p, stops, msg, size) != 0) return 1;
    if (mk_mech_rhs(p, stops, d->s.y, seen[0], seen[1], dy, &fault) != 0) {
        mk_mech_fault_message(&fault, msg, size);
        return 1;
    }
    for (i = 0; i < MK_ME_NX; i++) dx[i] = dy[i];
    return 0;
}

int mk_model_event_indicators(const mk_data *d, double *z, char *msg, size_t size)
{
    double p[MK_NPARAM], stops[2], out[MK_ME_NZ > 0 ? MK_ME_NZ : 1], seen[2];
    mk_fault fault = {0, 0, 0, 0, 0, 0};
    int i;
    mk_mech_seen_commands(d, seen);
    if (mk_mech_setup(d, p, stops, msg, size) != 0) return 1;
    if (mk_mech_event_indicators(p, stops, d->s.y, seen[0], seen[1], out, &fault) != 0) {
        mk_mech_fault_message(&fault, msg, size);
        return 1;
    }
    for (i = 0; i < MK_ME_NZ; i++) z[i] = out[i];
    return 0;
}
