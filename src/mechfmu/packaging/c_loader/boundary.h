/*
 * mechfmu's C loader, the FMI boundary: what fmi2.c and fmi3.c check before they forward a
 * call to pythonfmu's library, so that every call outside the standard's state machine, with
 * an unknown value reference, a variable of another type, or a variable that may not be set
 * in the current state is answered with an error status and a log line, and never reaches
 * Python (where pythonfmu 0.7 turns an exception into fmi2Fatal and breaks the interpreter's
 * GIL state: the host crashes at its next call).
 *
 * The FMU's variables come from a table generated at build time from its own
 * modelDescription.xml (src/mechfmu/packaging/boundary.py writes it, one per FMU):
 * MF_MODEL below. Standard C, POSIX threads and nothing else.
 */
#ifndef MECHFMU_BOUNDARY_H
#define MECHFMU_BOUNDARY_H

#include <stddef.h>

/* The type of a variable, as the get and set functions of both FMI versions see it (an FMI
 * 2.0 Enumeration is read with fmi2GetInteger: MF_INT32; an FMI 3.0 one with fmi3GetInt64). */
enum mf_type {
    MF_NONE = 0, /* no variable has this value reference */
    MF_FLOAT32,
    MF_FLOAT64,
    MF_INT8,
    MF_UINT8,
    MF_INT16,
    MF_UINT16,
    MF_INT32,
    MF_UINT32,
    MF_INT64,
    MF_UINT64,
    MF_BOOLEAN,
    MF_STRING,
    MF_BINARY,
    MF_CLOCK
};

enum mf_causality {
    MF_PARAMETER,
    MF_CALCULATED_PARAMETER,
    MF_INPUT,
    MF_OUTPUT,
    MF_LOCAL,
    MF_INDEPENDENT,
    MF_STRUCTURAL_PARAMETER
};

enum mf_variability { MF_CONSTANT, MF_FIXED, MF_TUNABLE, MF_DISCRETE, MF_CONTINUOUS };

enum mf_initial { MF_INITIAL_NONE, MF_EXACT, MF_APPROX, MF_CALCULATED };

struct mf_variable {
    unsigned char type, causality, variability, initial;
    const char *name;
};

/* One FMU, generated from its modelDescription.xml. */
struct mf_model {
    int fmi_version;        /* 2 or 3 */
    const char *identifier; /* modelIdentifier */
    const char *token;      /* FMI 2.0 guid, FMI 3.0 instantiationToken */
    unsigned reference_count; /* entries of variables: indexed by value reference */
    const struct mf_variable *variables;
    size_t category_count;  /* its LogCategories */
    const char *const *categories;
};

extern const struct mf_model MF_MODEL;

/* When a set is made: the three phases in which the standard allows some sets. */
enum mf_phase { MF_PHASE_INSTANTIATED, MF_PHASE_INITIALIZATION, MF_PHASE_STEP };

#define MF_WHY_SIZE 1024

/* 1 when every value reference of refs[0..n) names a variable of ``type`` that may be read
 * (``phase`` < 0) or set in ``phase``; otherwise 0 and the reason in ``why`` (names the
 * variable, its value reference and the rule). ``function`` names the call. */
int mf_check_references(const char *function, const unsigned refs[], size_t n, int type,
                        int phase, char why[MF_WHY_SIZE]);

/* 1 when ``category`` is one of the FMU's log categories. */
int mf_known_category(const char *category);

/* ---- The instances a loader handed out (pointers a host passes back are checked) ---- */

void mf_register(const void *instance);
void mf_unregister(const void *instance);
int mf_registered(const void *instance);

/* ---- FMU states: the loader's record of each state pythonfmu's library handed out ---- */

struct mf_state {
    void *real;     /* pythonfmu's own FMU state */
    int machine;    /* the loader's state-machine state when it was taken */
    double time;    /* the instance's time then (s) */
    struct mf_state *next;
};

void mf_state_remove(struct mf_state **list, struct mf_state *state);

/* The record of the FMU state ``state`` a host passes to ``function``, or NULL with ``why``
 * (none of this instance's: never handed out, or freed). */
struct mf_state *mf_state_known(struct mf_state *list, const void *state, const char *function,
                                char why[MF_WHY_SIZE]);

/* Where a state that ``function`` makes goes: 1 when *slot is NULL (a new record, *reuse
 * NULL) or one of this instance's states (*reuse: that record, reused as both standards
 * allow); 0 with ``why`` otherwise (also for a NULL ``slot``). */
int mf_state_slot(struct mf_state *list, void *const *slot, const char *function,
                  struct mf_state **reuse, char why[MF_WHY_SIZE]);

/* Keeps pythonfmu's state ``real`` where mf_state_slot said: in ``reuse`` after ``release``
 * of the state it held, or in a new record stored at *slot. 0 when out of memory (``real``
 * released). */
int mf_state_keep(struct mf_state **list, struct mf_state *reuse, void **slot, void *real,
                  int machine, double time, void (*release)(void *context, void **real),
                  void *context);

/* ---- Serialised FMU states: a versioned, checked frame around pythonfmu's bytes ----
 *
 *  offset  size  content (little endian)
 *   0      8     "MECHFMUS"
 *   8      4     format version (1)
 *  12      4     FMI version (2 or 3)
 *  16      4     state-machine state
 *  20      4     length L of the instantiation token (FMI 2.0: the guid)
 *  24      8     the instance's time (IEEE 754 double)
 *  32      8     length N of pythonfmu's bytes
 *  40      8     FNV-1a 64 of bytes 8..40 and 48..48+L+N
 *  48      L     the token
 *  48+L    N     pythonfmu's bytes (the model's state as JSON, runtime/fmi/state.py)
 */
#define MF_FRAME_HEADER 48
#define MF_FRAME_FORMAT 1

/* The frame's size around ``payload_size`` bytes of pythonfmu's. */
size_t mf_frame_size(size_t payload_size);
/* Where pythonfmu's bytes go in a frame. */
size_t mf_frame_payload_offset(void);
/* Writes the header and token of a frame whose payload is already in place. */
void mf_frame_write(unsigned char *frame, size_t payload_size, int machine, double time);
/* Checks a frame of ``size`` bytes: 1 and its payload, state and time; or 0 and why. */
int mf_frame_read(const unsigned char *frame, size_t size, const unsigned char **payload,
                  size_t *payload_size, int *machine, double *time, char why[MF_WHY_SIZE]);

/* Whether t + h reaches beyond ``stop`` by more than the rounding of the host's clock. */
int mf_beyond(double time, double stop);

#endif
