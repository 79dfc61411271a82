/*
 * Two small FMI 2.0 co-simulation FMUs of the suite's own, for testing our master as an
 * importer of FMUs that are not ours (tests/foreign_fmus.py builds them with the system C
 * compiler; their model descriptions are the .xml files beside this one).
 *
 *   -DTEST_SIGNALS  TestSignals: a variable of every FMI 2.0 type (Real, Integer, Boolean,
 *                   String, Enumeration), parameters, inputs and outputs, declared types
 *                   with units, a DefaultExperiment;
 *                     y = gain * u + x (x if not enabled), x' = u (x: the integral of u),
 *                     n = k + offset + steps taken, flag = b and enabled, mode_out = e,
 *                     s_out = label ":" s.
 *   -DTEST_STAIR    TestStair: counts its steps (counter) and asks to end the simulation at
 *                   t = limit: the step that would pass it stops there and returns
 *                   fmi2Discard, fmi2GetBooleanStatus(fmi2Terminated) is then true and
 *                   fmi2GetRealStatus(fmi2LastSuccessfulTime) the limit.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define TEXT 128

typedef struct {
    fmi2CallbackFunctions callbacks;
    char name[TEXT];
    double time;
    int terminated, steps;
    double gain, u, x;
    int offset, k, e, mode, enabled, b;
    char label[TEXT], s[TEXT], s_out[2 * TEXT + 2];
    double limit;
} Instance;

#ifdef TEST_STAIR
static void say(Instance *instance, fmi2Status status, const char *text)
{
    if (instance->callbacks.logger) {
        instance->callbacks.logger(instance->callbacks.componentEnvironment, instance->name,
                                   status, "logAll", "%s", text);
    }
}

#endif

static void copy_text(char *target, fmi2String source)
{
    snprintf(target, TEXT, "%s", source ? source : "");
}

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn)
{
    Instance *instance;
    (void)fmuType, (void)fmuGUID, (void)fmuResourceLocation, (void)visible, (void)loggingOn;
    instance = calloc(1, sizeof *instance);
    if (!instance) return NULL;
    if (functions) instance->callbacks = *functions;
    copy_text(instance->name, instanceName);
    instance->gain = 2.0;
    instance->offset = 3;
    instance->enabled = 1;
    copy_text(instance->label, "tag");
    instance->mode = 2;
    instance->u = 0.5;
    instance->k = 1;
    copy_text(instance->s, "in");
    instance->e = 1;
    instance->limit = 0.75;
    return instance;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) { free(c); }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n,
                                           const fmi2String categories[])
{
    (void)c, (void)loggingOn, (void)n, (void)categories;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                                           fmi2Real tolerance, fmi2Real startTime,
                                           fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    ((Instance *)c)->time = startTime;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }
FMI2_Export fmi2Status fmi2Reset(fmi2Component c) { (void)c; return fmi2Error; }

#ifndef TEST_STAIR
static double y_of(const Instance *instance)
{
    return instance->enabled ? instance->gain * instance->u + instance->x : instance->x;
}
#endif

static const char *s_out_of(Instance *instance)
{
    snprintf(instance->s_out, sizeof instance->s_out, "%s:%s", instance->label, instance->s);
    return instance->s_out;
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   fmi2Real value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
#ifdef TEST_STAIR
        switch (vr[i]) {
        case 0: value[i] = instance->limit; break;
        case 2: value[i] = instance->time; break;
        default: return fmi2Error;
        }
#else
        switch (vr[i]) {
        case 0: value[i] = instance->gain; break;
        case 5: value[i] = instance->u; break;
        case 10: value[i] = y_of(instance); break;
        case 11: value[i] = instance->x; break;
        default: return fmi2Error;
        }
#endif
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
#ifdef TEST_STAIR
        if (vr[i] != 1) return fmi2Error;
        value[i] = instance->steps;
#else
        switch (vr[i]) {
        case 1: value[i] = instance->offset; break;
        case 4: value[i] = instance->mode; break;
        case 6: value[i] = instance->k; break;
        case 9: value[i] = instance->e; break;
        case 12: value[i] = instance->k + instance->offset + instance->steps; break;
        case 14: value[i] = instance->e; break;
        default: return fmi2Error;
        }
#endif
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case 2: value[i] = instance->enabled; break;
        case 7: value[i] = instance->b; break;
        case 13: value[i] = instance->b && instance->enabled; break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case 3: value[i] = instance->label; break;
        case 8: value[i] = instance->s; break;
        case 15: value[i] = s_out_of(instance); break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
#ifdef TEST_STAIR
        if (vr[i] != 0) return fmi2Error;
        instance->limit = value[i];
#else
        switch (vr[i]) {
        case 0: instance->gain = value[i]; break;
        case 5: instance->u = value[i]; break;
        default: return fmi2Error;
        }
#endif
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case 1: instance->offset = value[i]; break;
        case 4: instance->mode = value[i]; break;
        case 6: instance->k = value[i]; break;
        case 9: instance->e = value[i]; break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case 2: instance->enabled = value[i] != 0; break;
        case 7: instance->b = value[i] != 0; break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[])
{
    Instance *instance = c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case 3: copy_text(instance->label, value[i]); break;
        case 8: copy_text(instance->s, value[i]); break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    Instance *instance = c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (instance->terminated) return fmi2Error;
#ifdef TEST_STAIR
    if (t + h > instance->limit + 1e-12) {
        instance->time = instance->limit;
        instance->terminated = 1;
        say(instance, fmi2Discard, "the stair has reached its limit: end of the simulation");
        return fmi2Discard;
    }
#else
    instance->x += instance->u * h;
#endif
    instance->steps++;
    instance->time = t + h;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s,
                                            fmi2Boolean *value)
{
    if (s != fmi2Terminated) return fmi2Discard;
    *value = ((Instance *)c)->terminated;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s,
                                         fmi2Real *value)
{
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = ((Instance *)c)->time;
    return fmi2OK;
}

/* Everything else: not provided. */
#define STUB(name, params) \
    FMI2_Export fmi2Status fmi2##name params { return fmi2Error; }
#pragma GCC diagnostic ignored "-Wunused-parameter"
STUB(GetStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Status *value))
STUB(GetIntegerStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Integer *value))
STUB(GetStringStatus, (fmi2Component c, const fmi2StatusKind s, fmi2String *value))
STUB(CancelStep, (fmi2Component c))
STUB(GetFMUstate, (fmi2Component c, fmi2FMUstate *state))
STUB(SetFMUstate, (fmi2Component c, fmi2FMUstate state))
STUB(FreeFMUstate, (fmi2Component c, fmi2FMUstate *state))
STUB(SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate state, size_t *size))
STUB(SerializeFMUstate, (fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size))
STUB(DeSerializeFMUstate,
     (fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state))
STUB(GetDirectionalDerivative,
     (fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference k[],
      size_t nk, const fmi2Real dk[], fmi2Real du[]))
STUB(SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                               const fmi2Integer order[], const fmi2Real value[]))
STUB(GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                const fmi2Integer order[], fmi2Real value[]))
