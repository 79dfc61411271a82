/*
 * mechfmu's C loader, the FMI boundary (see boundary.h): value references, types and the
 * standard's rules for setting variables; the instances and FMU states handed out; the frame
 * of serialised FMU states.
 */
#include "boundary.h"

#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- Variables ---- */

/* The name of a type in the FMI version's own words (Real or Float64, Integer or Int32...). */
static const char *type_name(int type)
{
    static const char *const fmi2[] = {"(none)", "Float32", "Real", "Int8", "UInt8", "Int16",
                                       "UInt16", "Integer", "UInt32", "Int64", "UInt64",
                                       "Boolean", "String", "Binary", "Clock"};
    static const char *const fmi3[] = {"(none)", "Float32", "Float64", "Int8", "UInt8", "Int16",
                                       "UInt16", "Int32", "UInt32", "Int64", "UInt64",
                                       "Boolean", "String", "Binary", "Clock"};
    if (type < MF_NONE || type > MF_CLOCK) return "(unknown type)";
    return MF_MODEL.fmi_version == 2 ? fmi2[type] : fmi3[type];
}

static const char *causality_name(int causality)
{
    static const char *const names[] = {"a parameter", "a calculated parameter", "an input",
                                        "an output", "a local variable",
                                        "the independent variable", "a structural parameter"};
    return causality >= 0 && causality <= MF_STRUCTURAL_PARAMETER ? names[causality] : "?";
}

/* Why a variable may not be set in ``phase`` (the standard's rules), or NULL when it may. */
static const char *set_refusal(const struct mf_variable *variable, int phase)
{
    int settable_start = variable->initial == MF_EXACT || variable->initial == MF_APPROX;
    if (variable->causality == MF_INDEPENDENT) {
        return "is the independent variable: only the step functions advance it";
    }
    if (variable->variability == MF_CONSTANT) return "is a constant";
    switch (phase) {
    case MF_PHASE_INSTANTIATED:
        /* start and guess values (initial exact or approx), and inputs */
        if (settable_start || variable->causality == MF_INPUT) return NULL;
        break;
    case MF_PHASE_INITIALIZATION:
        if (variable->initial == MF_EXACT || variable->causality == MF_INPUT) return NULL;
        break;
    default:
        if (variable->causality == MF_INPUT) return NULL;
        if (variable->causality == MF_PARAMETER && variable->variability == MF_TUNABLE) {
            return NULL;
        }
        if (variable->causality == MF_PARAMETER || variable->causality == MF_STRUCTURAL_PARAMETER) {
            return MF_MODEL.fmi_version == 2
                       ? "is a fixed parameter: it can be set only before "
                         "fmi2ExitInitializationMode (reset the instance to change it)"
                       : "is a fixed parameter: it can be set only before "
                         "fmi3ExitInitializationMode (reset the instance to change it)";
        }
        break;
    }
    if (variable->causality == MF_OUTPUT) return "is an output: the FMU computes it";
    if (variable->initial == MF_CALCULATED) return "is calculated by the FMU";
    return "cannot be set in this state";
}

int mf_check_references(const char *function, const unsigned refs[], size_t n, int type,
                        int phase, char why[MF_WHY_SIZE])
{
    size_t i;
    if (n > 0 && refs == NULL) {
        snprintf(why, MF_WHY_SIZE, "%s: the array of value references is NULL (%zu expected)",
                 function, n);
        return 0;
    }
    for (i = 0; i < n; i++) {
        unsigned reference = refs[i];
        const struct mf_variable *variable;
        const char *refusal;
        if (reference >= MF_MODEL.reference_count
            || MF_MODEL.variables[reference].type == MF_NONE) {
            snprintf(why, MF_WHY_SIZE,
                     "%s: value reference %u (position %zu) names no variable of %s", function,
                     reference, i, MF_MODEL.identifier);
            return 0;
        }
        variable = &MF_MODEL.variables[reference];
        if (variable->type != type) {
            snprintf(why, MF_WHY_SIZE,
                     "%s: %s (value reference %u) is of type %s, not %s: use fmi%dGet%s or "
                     "fmi%dSet%s",
                     function, variable->name, reference, type_name(variable->type),
                     type_name(type), MF_MODEL.fmi_version, type_name(variable->type),
                     MF_MODEL.fmi_version, type_name(variable->type));
            return 0;
        }
        if (phase >= 0 && (refusal = set_refusal(variable, phase)) != NULL) {
            snprintf(why, MF_WHY_SIZE, "%s: %s (value reference %u, %s) %s", function,
                     variable->name, reference, causality_name(variable->causality), refusal);
            return 0;
        }
    }
    return 1;
}

int mf_known_category(const char *category)
{
    size_t i;
    if (!category) return 0;
    for (i = 0; i < MF_MODEL.category_count; i++) {
        if (strcmp(MF_MODEL.categories[i], category) == 0) return 1;
    }
    return 0;
}

/* ---- Instances ---- */

static pthread_mutex_t registry_lock = PTHREAD_MUTEX_INITIALIZER;
static const void **registry;
static size_t registry_size, registry_capacity;

void mf_register(const void *instance)
{
    pthread_mutex_lock(&registry_lock);
    if (registry_size == registry_capacity) {
        size_t capacity = registry_capacity ? 2 * registry_capacity : 16;
        const void **grown = realloc(registry, capacity * sizeof *registry);
        if (!grown) {
            pthread_mutex_unlock(&registry_lock);
            return;
        }
        registry = grown;
        registry_capacity = capacity;
    }
    registry[registry_size++] = instance;
    pthread_mutex_unlock(&registry_lock);
}

void mf_unregister(const void *instance)
{
    size_t i;
    pthread_mutex_lock(&registry_lock);
    for (i = 0; i < registry_size; i++) {
        if (registry[i] == instance) {
            registry[i] = registry[--registry_size];
            break;
        }
    }
    pthread_mutex_unlock(&registry_lock);
}

int mf_registered(const void *instance)
{
    size_t i;
    int found = 0;
    if (!instance) return 0;
    pthread_mutex_lock(&registry_lock);
    for (i = 0; i < registry_size && !found; i++) found = registry[i] == instance;
    pthread_mutex_unlock(&registry_lock);
    return found;
}

/* ---- FMU states ---- */

/* A new record at the head of ``list``, or NULL when out of memory. */
static struct mf_state *state_new(struct mf_state **list, void *real, int machine, double time)
{
    struct mf_state *state = calloc(1, sizeof *state);
    if (!state) return NULL;
    state->real = real;
    state->machine = machine;
    state->time = time;
    state->next = *list;
    *list = state;
    return state;
}

/* The record of ``list`` that is ``state``, or NULL. */
static struct mf_state *state_find(struct mf_state *list, const void *state)
{
    for (; list; list = list->next) {
        if (list == state) return list;
    }
    return NULL;
}

void mf_state_remove(struct mf_state **list, struct mf_state *state)
{
    for (; *list; list = &(*list)->next) {
        if (*list == state) {
            *list = state->next;
            free(state);
            return;
        }
    }
}

static const char *getter_names(void)
{
    return MF_MODEL.fmi_version == 2 ? "fmi2GetFMUstate or fmi2DeSerializeFMUstate"
                                     : "fmi3GetFMUState or fmi3DeserializeFMUState";
}

struct mf_state *mf_state_known(struct mf_state *list, const void *state, const char *function,
                                char why[MF_WHY_SIZE])
{
    struct mf_state *record = state_find(list, state);
    if (!record) {
        snprintf(why, MF_WHY_SIZE,
                 "%s: %p is no FMU state of this instance (never returned by %s, or freed)",
                 function, state, getter_names());
    }
    return record;
}

int mf_state_slot(struct mf_state *list, void *const *slot, const char *function,
                  struct mf_state **reuse, char why[MF_WHY_SIZE])
{
    *reuse = NULL;
    if (!slot) {
        snprintf(why, MF_WHY_SIZE, "%s: the pointer to the FMU state is NULL", function);
        return 0;
    }
    if (!*slot) return 1;
    *reuse = mf_state_known(list, *slot, function, why);
    return *reuse != NULL;
}

int mf_state_keep(struct mf_state **list, struct mf_state *reuse, void **slot, void *real,
                  int machine, double time, void (*release)(void *context, void **real),
                  void *context)
{
    struct mf_state *record = reuse;
    if (record) {
        release(context, &record->real);
        record->real = real;
        record->machine = machine;
        record->time = time;
        return 1;
    }
    record = state_new(list, real, machine, time);
    if (!record) {
        release(context, &real);
        return 0;
    }
    *slot = record;
    return 1;
}

/* ---- Frames ---- */

static const unsigned char MAGIC[8] = {'M', 'E', 'C', 'H', 'F', 'M', 'U', 'S'};

/* Where each field of the header starts (the table in boundary.h). */
enum {
    AT_FORMAT = 8,
    AT_FMI_VERSION = 12,
    AT_MACHINE = 16,
    AT_TOKEN_LENGTH = 20,
    AT_TIME = 24,
    AT_PAYLOAD_LENGTH = 32,
    AT_CHECKSUM = 40
};

static void put32(unsigned char *out, uint32_t value)
{
    int i;
    for (i = 0; i < 4; i++) out[i] = (unsigned char)(value >> (8 * i));
}

static void put64(unsigned char *out, uint64_t value)
{
    int i;
    for (i = 0; i < 8; i++) out[i] = (unsigned char)(value >> (8 * i));
}

static uint32_t get32(const unsigned char *in)
{
    uint32_t value = 0;
    int i;
    for (i = 3; i >= 0; i--) value = (value << 8) | in[i];
    return value;
}

static uint64_t get64(const unsigned char *in)
{
    uint64_t value = 0;
    int i;
    for (i = 7; i >= 0; i--) value = (value << 8) | in[i];
    return value;
}

/* FNV-1a, 64 bits (Fowler, Noll, Vo): its offset basis and prime. */
#define FNV_OFFSET_BASIS 0xcbf29ce484222325ULL
#define FNV_PRIME 0x100000001b3ULL

static uint64_t fnv1a(uint64_t hash, const unsigned char *bytes, size_t size)
{
    size_t i;
    for (i = 0; i < size; i++) {
        hash ^= bytes[i];
        hash *= FNV_PRIME;
    }
    return hash;
}

static uint64_t frame_checksum(const unsigned char *frame, size_t body)
{
    /* the header's fields from the format to the checksum, then the token and payload */
    uint64_t hash = fnv1a(FNV_OFFSET_BASIS, frame + AT_FORMAT, AT_CHECKSUM - AT_FORMAT);
    return fnv1a(hash, frame + MF_FRAME_HEADER, body);
}

size_t mf_frame_payload_offset(void)
{
    return MF_FRAME_HEADER + strlen(MF_MODEL.token);
}

size_t mf_frame_size(size_t payload_size)
{
    return mf_frame_payload_offset() + payload_size;
}

void mf_frame_write(unsigned char *frame, size_t payload_size, int machine, double time)
{
    size_t token = strlen(MF_MODEL.token);
    uint64_t bits;
    memcpy(frame, MAGIC, sizeof MAGIC);
    put32(frame + AT_FORMAT, MF_FRAME_FORMAT);
    put32(frame + AT_FMI_VERSION, (uint32_t)MF_MODEL.fmi_version);
    put32(frame + AT_MACHINE, (uint32_t)machine);
    put32(frame + AT_TOKEN_LENGTH, (uint32_t)token);
    memcpy(&bits, &time, sizeof bits);
    put64(frame + AT_TIME, bits);
    put64(frame + AT_PAYLOAD_LENGTH, (uint64_t)payload_size);
    memcpy(frame + MF_FRAME_HEADER, MF_MODEL.token, token);
    put64(frame + AT_CHECKSUM, frame_checksum(frame, token + payload_size));
}

int mf_frame_read(const unsigned char *frame, size_t size, const unsigned char **payload,
                  size_t *payload_size, int *machine, double *time, char why[MF_WHY_SIZE])
{
    uint64_t token, body, bits;
    size_t own = strlen(MF_MODEL.token);
    if (!frame) {
        snprintf(why, MF_WHY_SIZE, "the serialized FMU state is a NULL pointer");
        return 0;
    }
    if (size < MF_FRAME_HEADER) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state has %zu bytes, fewer than its %d-byte header: it is "
                 "truncated or not a state of this FMU",
                 size, MF_FRAME_HEADER);
        return 0;
    }
    if (memcmp(frame, MAGIC, sizeof MAGIC) != 0) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state does not start with mechfmu's header \"MECHFMUS\": it "
                 "was not written by a mechfmu FMU");
        return 0;
    }
    if (get32(frame + AT_FORMAT) != MF_FRAME_FORMAT) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state has format version %u; this FMU reads version %d",
                 (unsigned)get32(frame + AT_FORMAT), MF_FRAME_FORMAT);
        return 0;
    }
    if (get32(frame + AT_FMI_VERSION) != (uint32_t)MF_MODEL.fmi_version) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state was written by an FMI %u.0 FMU; this one is FMI %d.0",
                 (unsigned)get32(frame + AT_FMI_VERSION), MF_MODEL.fmi_version);
        return 0;
    }
    token = get32(frame + AT_TOKEN_LENGTH);
    body = get64(frame + AT_PAYLOAD_LENGTH);
    if (token > size || body > size || MF_FRAME_HEADER + token + body != size) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state has %zu bytes, its header announces %llu: it is "
                 "truncated or damaged",
                 size, (unsigned long long)(MF_FRAME_HEADER + token + body));
        return 0;
    }
    if (get64(frame + AT_CHECKSUM) != frame_checksum(frame, (size_t)(token + body))) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state's checksum does not match its bytes: it was changed "
                 "or damaged");
        return 0;
    }
    if (token != own || memcmp(frame + MF_FRAME_HEADER, MF_MODEL.token, own) != 0) {
        snprintf(why, MF_WHY_SIZE,
                 "the serialized FMU state was saved by another FMU or another build of %s "
                 "(instantiation token \"%.*s\"; this FMU's is \"%s\")",
                 MF_MODEL.identifier, (int)(token < 200 ? token : 200),
                 (const char *)frame + MF_FRAME_HEADER, MF_MODEL.token);
        return 0;
    }
    bits = get64(frame + AT_TIME);
    memcpy(time, &bits, sizeof *time);
    *machine = (int)get32(frame + AT_MACHINE);
    *payload = frame + MF_FRAME_HEADER + token;
    *payload_size = (size_t)body;
    return 1;
}

int mf_beyond(double time, double stop)
{
    double scale = stop < 0 ? -stop : stop;
    return time - stop > 1e-9 * (scale > 1.0 ? scale : 1.0);
}
