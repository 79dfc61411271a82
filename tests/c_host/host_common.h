/*
 * What host.c (FMI 2.0) and host3.c (FMI 3.0) share: inputs and outputs given on the command
 * line, looking up FMI functions, timing, and naming the libpython a run ended up with.
 * Define HOST_NAME ("host" or "host3") before including it.
 */
#ifndef HOST_COMMON_H
#define HOST_COMMON_H

#include <dlfcn.h>
#include <link.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAX_VARIABLES 64

/* A Real input: a + b t + c sin(w t) + d cos(w t) at communication point t. */
typedef struct {
    unsigned int vr;
    double a, b, c, d, w;
} Input;

/* An output to print: type r (Real/Float64), i (Integer/Int32) or b (Boolean). */
typedef struct {
    char type;
    unsigned int vr;
} Output;

static double input_value(const Input *input, double t)
{
    return input->a + input->b * t + input->c * sin(input->w * t) + input->d * cos(input->w * t);
}

/* "VR=a[,b,c,d,w]"; 0 when malformed (named on stderr). */
static int parse_input(const char *text, Input *input)
{
    memset(input, 0, sizeof *input);
    if (sscanf(text, "%u=%lf,%lf,%lf,%lf,%lf", &input->vr, &input->a, &input->b, &input->c,
               &input->d, &input->w) < 2) {
        fprintf(stderr, HOST_NAME ": bad input '%s'\n", text);
        return 0;
    }
    return 1;
}

/* "TYPE:VR"; 0 when malformed (named on stderr). */
static int parse_output(const char *text, Output *output)
{
    if (sscanf(text, "%c:%u", &output->type, &output->vr) != 2 || !strchr("rib", output->type)) {
        fprintf(stderr, HOST_NAME ": bad output '%s'\n", text);
        return 0;
    }
    return 1;
}

static void *resolve(void *library, const char *name)
{
    void *address = dlsym(library, name);
    if (!address) {
        fprintf(stderr, HOST_NAME ": %s not found: %s\n", name, dlerror());
        exit(2);
    }
    return address;
}

static double seconds_between(const struct timespec *before, const struct timespec *after)
{
    return (double)(after->tv_sec - before->tv_sec) + 1e-9 * (after->tv_nsec - before->tv_nsec);
}

/* dl_iterate_phdr callback: name each libpython mapped into this process. */
static int name_libpython(struct dl_phdr_info *info, size_t size, void *data)
{
    const char *base = info->dlpi_name ? strrchr(info->dlpi_name, '/') : NULL;
    (void)size;
    (void)data;
    if (base && strncmp(base + 1, "libpython", 9) == 0) {
        fprintf(stderr, HOST_NAME ": loaded %s\n", info->dlpi_name);
    }
    return 0;
}

#endif
