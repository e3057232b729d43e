/* A minimal FMI co-simulation host in C, for the FMU tests.
 *
 * It loads an FMU's binary as C and C++ simulation tools do, with
 * dlopen(RTLD_NOW | RTLD_LOCAL) in a process without Python, instantiates it
 * (FMI 2.0 or 3.0), sets parameters, drives the input u with
 * u(t) = offset + amplitude * cos(2 pi f t) at t = k h, steps it and prints
 * t and the requested outputs as CSV (%.17g) on stdout. FMU log messages go to
 * stderr. It then terminates and frees the instance and returns from main, so
 * the process exits through the FMU's library destructors, as a tool does.
 *
 * Usage:
 *   fmu_c_host FMI BINARY RESOURCES TOKEN U_VR STEPS H FREQ AMPLITUDE OFFSET [SET...] -- VR...
 *     FMI        2 or 3
 *     BINARY     path of binaries/<platform>/<modelIdentifier>.so
 *     RESOURCES  absolute path of the unzipped FMU's resources directory
 *     TOKEN      guid (FMI 2.0) or instantiationToken (FMI 3.0)
 *     U_VR       value reference of the Real/Float64 input u
 *     SET        r:VR=VALUE (Real/Float64), b:VR=0|1 (Boolean), s:VR=TEXT (String)
 *     VR...      value references of the Real/Float64 outputs to print
 *
 * Exit status: 0 when every call returned OK or Warning; 1 for a usage or load
 * error; 2 when a call returned Discard, 3 Error, 4 Fatal (printed on stderr).
 *
 * The FMI types and function signatures below are declared here from the FMI 2.0
 * and 3.0 standards (fmi-standard.org); this file includes no FMI header.
 */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- FMI 2.0 (co-simulation) ---------------------------------------------------- */
typedef void *Fmi2Component;
typedef void (*Fmi2Logger)(void *env, const char *instance, int status, const char *category,
                           const char *message, ...);
typedef struct {
    Fmi2Logger logger;
    void *(*allocate_memory)(size_t count, size_t size);
    void (*free_memory)(void *pointer);
    void (*step_finished)(void *env, int status);
    void *environment;
} Fmi2Callbacks;
typedef Fmi2Component (*Fmi2Instantiate)(const char *instance, int type, const char *guid,
                                         const char *resource_uri, const Fmi2Callbacks *callbacks,
                                         int visible, int logging_on);
typedef int (*Fmi2SetupExperiment)(Fmi2Component c, int tolerance_defined, double tolerance,
                                   double start, int stop_defined, double stop);
typedef int (*Fmi2Call)(Fmi2Component c);
typedef int (*Fmi2SetReal)(Fmi2Component c, const unsigned int vr[], size_t n, const double v[]);
typedef int (*Fmi2GetReal)(Fmi2Component c, const unsigned int vr[], size_t n, double v[]);
typedef int (*Fmi2SetBoolean)(Fmi2Component c, const unsigned int vr[], size_t n, const int v[]);
typedef int (*Fmi2SetString)(Fmi2Component c, const unsigned int vr[], size_t n,
                             const char *const v[]);
typedef int (*Fmi2DoStep)(Fmi2Component c, double t, double h, int no_set_state_prior);
typedef void (*Fmi2FreeInstance)(Fmi2Component c);
enum { FMI2_COSIMULATION = 1 };

/* ---- FMI 3.0 (co-simulation) ---------------------------------------------------- */
typedef void *Fmi3Instance;
typedef void (*Fmi3LogMessage)(void *env, int status, const char *category, const char *message);
typedef void (*Fmi3IntermediateUpdate)(void *env, double time, bool set_requested,
                                       bool get_requested, bool step_finished,
                                       bool can_return_early, bool *early_return_requested,
                                       double *early_return_time);
typedef Fmi3Instance (*Fmi3InstantiateCoSimulation)(
    const char *instance, const char *token, const char *resource_path, bool visible,
    bool logging_on, bool event_mode_used, bool early_return_allowed,
    const uint32_t required_intermediate[], size_t n_required, void *env,
    Fmi3LogMessage log_message, Fmi3IntermediateUpdate intermediate_update);
typedef int (*Fmi3EnterInitializationMode)(Fmi3Instance i, bool tolerance_defined,
                                           double tolerance, double start, bool stop_defined,
                                           double stop);
typedef int (*Fmi3Call)(Fmi3Instance i);
typedef int (*Fmi3SetFloat64)(Fmi3Instance i, const uint32_t vr[], size_t n, const double v[],
                              size_t nv);
typedef int (*Fmi3GetFloat64)(Fmi3Instance i, const uint32_t vr[], size_t n, double v[],
                              size_t nv);
typedef int (*Fmi3SetBoolean)(Fmi3Instance i, const uint32_t vr[], size_t n, const bool v[],
                              size_t nv);
typedef int (*Fmi3SetString)(Fmi3Instance i, const uint32_t vr[], size_t n,
                             const char *const v[], size_t nv);
typedef int (*Fmi3DoStep)(Fmi3Instance i, double t, double h, bool no_set_state_prior,
                          bool *event_handling_needed, bool *terminate, bool *early_return,
                          double *last_successful_time);
typedef void (*Fmi3FreeInstance)(Fmi3Instance i);

static const char *STATUS[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
static int worst = 0;

static void log_fmi2(void *env, const char *instance, int status, const char *category,
                     const char *message, ...) {
    (void)env;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "[%s] %s: ", status >= 0 && status <= 5 ? STATUS[status] : "?",
            instance ? instance : "");
    vfprintf(stderr, message, args);
    fprintf(stderr, " (%s)\n", category ? category : "");
    va_end(args);
}

static void log_fmi3(void *env, int status, const char *category, const char *message) {
    (void)env;
    fprintf(stderr, "[%s] %s (%s)\n", status >= 0 && status <= 5 ? STATUS[status] : "?",
            message, category ? category : "");
}

/* Record a call's status; report anything worse than Warning. */
static int check(const char *what, int status) {
    if (status > 1) fprintf(stderr, "%s returned %s\n", what, STATUS[status > 5 ? 5 : status]);
    if (status > worst) worst = status;
    return status > 1;
}

static void *symbol(void *library, const char *name) {
    void *f = dlsym(library, name);
    if (!f) {
        fprintf(stderr, "missing FMI function %s\n", name);
        exit(1);
    }
    return f;
}

typedef struct {
    char kind;
    uint32_t vr;
    const char *text;
} Setting;

/* What the command line asks for. */
typedef struct {
    int fmi;
    const char *binary, *resources, *token;
    uint32_t u_vr;
    long steps;
    double h, frequency, amplitude, offset;
    Setting settings[64];
    uint32_t out[64];
    size_t n_settings, n_out;
} Run;

/* The command line into run: 0, or 1 after saying what is wrong. */
static int parse(int argc, char **argv, Run *run) {
    if (argc < 13) {
        fprintf(stderr, "usage: %s FMI BINARY RESOURCES TOKEN U_VR STEPS H FREQ AMPLITUDE "
                        "OFFSET [SET...] -- VR...\n", argv[0]);
        return 1;
    }
    run->fmi = atoi(argv[1]);
    run->binary = argv[2], run->resources = argv[3], run->token = argv[4];
    run->u_vr = (uint32_t)strtoul(argv[5], NULL, 10);
    run->steps = atol(argv[6]);
    run->h = atof(argv[7]), run->frequency = atof(argv[8]), run->amplitude = atof(argv[9]);
    run->offset = atof(argv[10]);
    run->n_settings = run->n_out = 0;
    int k = 11;
    for (; k < argc && strcmp(argv[k], "--") != 0 && run->n_settings < 64; k++) {
        char *eq = strchr(argv[k], '=');
        if (strlen(argv[k]) < 4 || argv[k][1] != ':' || !eq) {
            fprintf(stderr, "bad setting %s\n", argv[k]);
            return 1;
        }
        Setting *setting = &run->settings[run->n_settings++];
        setting->kind = argv[k][0];
        setting->vr = (uint32_t)strtoul(argv[k] + 2, NULL, 10);
        setting->text = eq + 1;
    }
    for (k++; k < argc && run->n_out < 64; k++)
        run->out[run->n_out++] = (uint32_t)strtoul(argv[k], NULL, 10);
    if (run->n_out == 0) {
        fprintf(stderr, "no outputs given after --\n");
        return 1;
    }
    if (run->fmi != 2 && run->fmi != 3) {
        fprintf(stderr, "FMI must be 2 or 3, not %s\n", argv[1]);
        return 1;
    }
    return 0;
}

static void print_row(long n, double h, const double *values, size_t n_out) {
    printf("%.17g", (n + 1) * h);
    for (size_t j = 0; j < n_out; j++) printf(",%.17g", values[j]);
    printf("\n");
}

/* The FMI 2.0 run: 0, or 4 when instantiation failed. */
static int run_fmi2(void *library, const Run *run) {
    Fmi2Instantiate instantiate = (Fmi2Instantiate)symbol(library, "fmi2Instantiate");
    Fmi2SetupExperiment setup = (Fmi2SetupExperiment)symbol(library, "fmi2SetupExperiment");
    Fmi2Call enter = (Fmi2Call)symbol(library, "fmi2EnterInitializationMode");
    Fmi2Call exit_init = (Fmi2Call)symbol(library, "fmi2ExitInitializationMode");
    Fmi2Call terminate = (Fmi2Call)symbol(library, "fmi2Terminate");
    Fmi2SetReal set_real = (Fmi2SetReal)symbol(library, "fmi2SetReal");
    Fmi2GetReal get_real = (Fmi2GetReal)symbol(library, "fmi2GetReal");
    Fmi2SetBoolean set_boolean = (Fmi2SetBoolean)symbol(library, "fmi2SetBoolean");
    Fmi2SetString set_string = (Fmi2SetString)symbol(library, "fmi2SetString");
    Fmi2DoStep do_step = (Fmi2DoStep)symbol(library, "fmi2DoStep");
    Fmi2FreeInstance free_instance = (Fmi2FreeInstance)symbol(library, "fmi2FreeInstance");
    static char uri[4096];
    double values[64];
    snprintf(uri, sizeof uri, "file://%s", run->resources);
    Fmi2Callbacks callbacks = {log_fmi2, calloc, free, NULL, NULL};
    Fmi2Component c = instantiate("c_host", FMI2_COSIMULATION, run->token, uri, &callbacks, 0, 1);
    if (!c) {
        fprintf(stderr, "fmi2Instantiate failed\n");
        return 4;
    }
    for (size_t s = 0; s < run->n_settings; s++) {
        unsigned int vr = run->settings[s].vr;
        if (run->settings[s].kind == 'r') {
            double v = atof(run->settings[s].text);
            check("fmi2SetReal", set_real(c, &vr, 1, &v));
        } else if (run->settings[s].kind == 'b') {
            int v = atoi(run->settings[s].text);
            check("fmi2SetBoolean", set_boolean(c, &vr, 1, &v));
        } else {
            check("fmi2SetString", set_string(c, &vr, 1, &run->settings[s].text));
        }
    }
    int failed = check("fmi2SetupExperiment", setup(c, 0, 0.0, 0.0, 0, 0.0))
                 || check("fmi2EnterInitializationMode", enter(c))
                 || check("fmi2ExitInitializationMode", exit_init(c));
    for (long n = 0; n < run->steps && !failed; n++) {
        double t = n * run->h;
        double u = run->offset + run->amplitude * cos(2.0 * M_PI * run->frequency * t);
        unsigned int vr = run->u_vr;
        if (check("fmi2SetReal", set_real(c, &vr, 1, &u))
            || check("fmi2DoStep", do_step(c, t, run->h, 1))
            || check("fmi2GetReal", get_real(c, run->out, run->n_out, values)))
            break;
        print_row(n, run->h, values, run->n_out);
    }
    if (worst < 4) {  /* after Fatal the standard allows no further call */
        check("fmi2Terminate", terminate(c));
        free_instance(c);
    }
    return 0;
}

/* The FMI 3.0 run: 0, or 4 when instantiation failed. */
static int run_fmi3(void *library, const Run *run) {
    Fmi3InstantiateCoSimulation instantiate =
        (Fmi3InstantiateCoSimulation)symbol(library, "fmi3InstantiateCoSimulation");
    Fmi3EnterInitializationMode enter =
        (Fmi3EnterInitializationMode)symbol(library, "fmi3EnterInitializationMode");
    Fmi3Call exit_init = (Fmi3Call)symbol(library, "fmi3ExitInitializationMode");
    Fmi3Call terminate = (Fmi3Call)symbol(library, "fmi3Terminate");
    Fmi3SetFloat64 set_float = (Fmi3SetFloat64)symbol(library, "fmi3SetFloat64");
    Fmi3GetFloat64 get_float = (Fmi3GetFloat64)symbol(library, "fmi3GetFloat64");
    Fmi3SetBoolean set_boolean = (Fmi3SetBoolean)symbol(library, "fmi3SetBoolean");
    Fmi3SetString set_string = (Fmi3SetString)symbol(library, "fmi3SetString");
    Fmi3DoStep do_step = (Fmi3DoStep)symbol(library, "fmi3DoStep");
    Fmi3FreeInstance free_instance = (Fmi3FreeInstance)symbol(library, "fmi3FreeInstance");
    double values[64];
    Fmi3Instance c = instantiate("c_host", run->token, run->resources, false, true, false, false,
                                 NULL, 0, NULL, log_fmi3, NULL);
    if (!c) {
        fprintf(stderr, "fmi3InstantiateCoSimulation failed\n");
        return 4;
    }
    for (size_t s = 0; s < run->n_settings; s++) {
        uint32_t vr = run->settings[s].vr;
        if (run->settings[s].kind == 'r') {
            double v = atof(run->settings[s].text);
            check("fmi3SetFloat64", set_float(c, &vr, 1, &v, 1));
        } else if (run->settings[s].kind == 'b') {
            bool v = atoi(run->settings[s].text) != 0;
            check("fmi3SetBoolean", set_boolean(c, &vr, 1, &v, 1));
        } else {
            check("fmi3SetString", set_string(c, &vr, 1, &run->settings[s].text, 1));
        }
    }
    int failed = check("fmi3EnterInitializationMode", enter(c, false, 0.0, 0.0, false, 0.0))
                 || check("fmi3ExitInitializationMode", exit_init(c));
    for (long n = 0; n < run->steps && !failed; n++) {
        double t = n * run->h, last = t;
        double u = run->offset + run->amplitude * cos(2.0 * M_PI * run->frequency * t);
        bool event = false, stop = false, early = false;
        if (check("fmi3SetFloat64", set_float(c, &run->u_vr, 1, &u, 1))
            || check("fmi3DoStep", do_step(c, t, run->h, true, &event, &stop, &early, &last))
            || check("fmi3GetFloat64", get_float(c, run->out, run->n_out, values, run->n_out)))
            break;
        print_row(n, run->h, values, run->n_out);
    }
    if (worst < 4) {
        check("fmi3Terminate", terminate(c));
        free_instance(c);
    }
    return 0;
}

int main(int argc, char **argv) {
    static Run run;
    if (parse(argc, argv, &run))
        return 1;
    void *library = dlopen(run.binary, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        fprintf(stderr, "cannot load %s: %s\n", run.binary, dlerror());
        return 1;
    }
    int status = run.fmi == 2 ? run_fmi2(library, &run) : run_fmi3(library, &run);
    if (status)
        return status;
    fflush(stdout);
    return worst > 1 ? worst : 0;
}
