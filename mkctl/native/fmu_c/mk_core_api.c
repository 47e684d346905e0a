/* The FMUs' side of the compiled core: fault messages in mkctl's words, and the one formula the core does not
 * generate (mkctl.physics.params.derived_turns uses math.sqrt, which cannot be traced on symbols; tested
 * against Params). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_fmu.h"
#include "mk_core_api.h"

/* generated with the core: per domain check, the library's message with markers for the numbers
 * (\001B value repr, \001b value %g, \001L / \001l low, \001H / \001h high); integrator messages */
extern const char *const mk_fmu_fault_templates[];
extern const int mk_fmu_fault_count;
extern const char MK_FMU_COLLAPSE_MESSAGE[];
extern const char MK_FMU_TOO_MANY_STEPS_MESSAGE[];

double mk_fmu_derived_turns(double b, double L0, double D0)
{
    return sqrt(b * b - L0 * L0) / (3.141592653589793 * D0);
}

double mk_turns(const mk_data *d)
{
    /* as the slaves do: n left at its start value while b, L0 or D0 changed follows them */
    int geometry_changed = d->v[VR_b] != mk_variables[VR_b].start || d->v[VR_L0] != mk_variables[VR_L0].start ||
                           d->v[VR_D0] != mk_variables[VR_D0].start;
    if (d->v[VR_n] == mk_variables[VR_n].start && geometry_changed)
        return mk_fmu_derived_turns(d->v[VR_b], d->v[VR_L0], d->v[VR_D0]);
    return d->v[VR_n];
}

void mk_fault_message(const mk_fault *fault, char *msg, size_t size)
{
    if (size == 0) return;
    msg[0] = '\0';
    switch (fault->code) {
    case 2: snprintf(msg, size, "%s", MK_FMU_COLLAPSE_MESSAGE); return;
    case 3: snprintf(msg, size, "%s", MK_FMU_TOO_MANY_STEPS_MESSAGE); return;
    case 1: break;
    case 4: snprintf(msg, size, "this parameter structure (model, friction, lag, slack) is not compiled into the core");
            return;
    default: snprintf(msg, size, "the compiled core failed (fault code %d)", fault->code); return;
    }
    if (fault->check < 0 || fault->check >= mk_fmu_fault_count) {
        snprintf(msg, size, "domain check %d failed with the value %g", fault->check, fault->value);
        return;
    }
    mk_fault_format(mk_fmu_fault_templates[fault->check], fault, msg, size);
}

void mk_fault_format(const char *template_text, const mk_fault *fault, char *msg, size_t size)
{
    const char *t;
    size_t j = 0;
    char number[40];
    if (size == 0) return;
    msg[0] = '\0';
    for (t = template_text; *t != '\0' && j + 1 < size; t++) {
        if (*t == '\001' && t[1] != '\0') {
            double x;
            int repr;
            t++;
            x = (*t == 'B' || *t == 'b') ? fault->value : (*t == 'L' || *t == 'l') ? fault->low : fault->high;
            repr = *t == 'B' || *t == 'L' || *t == 'H';
            if (repr) mk_repr(x, number, sizeof number);
            else snprintf(number, sizeof number, "%g", x);
            j += (size_t)snprintf(msg + j, size - j, "%s", number);
            if (j >= size) j = size - 1;
        } else {
            msg[j++] = *t;
        }
    }
    msg[j] = '\0';
}
