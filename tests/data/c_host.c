/* A minimal FMI 2.0 host in plain C, a second importer beside fmpy: proves the binary loads outside
 * Python (e.g. that libm is linked), and steps it with values set through fmi2SetReal.
 * Usage: c_host LIBRARY GUID STEPS OUT_VR [VR=VALUE ...] [-- VR=VALUE ...]   (4 ms steps; values before
 * "--" are set before initialisation (parameters), those after it once initialised (inputs), as fmpy's
 * users do; prints the output as %.17g) */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...) {
    (void)e; (void)n; (void)s; (void)c;
    fprintf(stderr, "%s\n", m);
}

int main(int argc, char **argv) {
    if (argc < 5) return 2;
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 3; }
    fmi2InstantiateTYPE *inst = (fmi2InstantiateTYPE *)dlsym(lib, "fmi2Instantiate");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)dlsym(lib, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter = (fmi2EnterInitializationModeTYPE *)dlsym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave = (fmi2ExitInitializationModeTYPE *)dlsym(lib, "fmi2ExitInitializationMode");
    fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)dlsym(lib, "fmi2DoStep");
    fmi2GetRealTYPE *get = (fmi2GetRealTYPE *)dlsym(lib, "fmi2GetReal");
    fmi2SetRealTYPE *set = (fmi2SetRealTYPE *)dlsym(lib, "fmi2SetReal");
    fmi2FreeInstanceTYPE *release = (fmi2FreeInstanceTYPE *)dlsym(lib, "fmi2FreeInstance");
    fmi2CallbackFunctions cb = {logger, NULL, NULL, NULL, NULL};
    fmi2Component c = inst("host", fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False);
    if (!c) return 4;
    int steps = atoi(argv[3]);
    fmi2ValueReference out_vr = (fmi2ValueReference)atoi(argv[4]);
    int i = 5;
    for (; i < argc && argv[i][0] != '-'; i++) {
        char *eq = NULL;
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], &eq, 10);
        fmi2Real value = strtod(eq + 1, NULL);
        if (set(c, &vr, 1, &value)) return 7;
    }
    double result = 0;
    if (setup(c, fmi2False, 0, 0, fmi2False, 0) || enter(c) || leave(c)) return 5;
    for (i++; i < argc; i++) {
        char *eq = NULL;
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], &eq, 10);
        fmi2Real value = strtod(eq + 1, NULL);
        if (set(c, &vr, 1, &value)) return 7;
    }
    for (int i = 0; i < steps; i++)
        if (step(c, i * 0.004, 0.004, fmi2True)) return 6;
    get(c, &out_vr, 1, &result);
    printf("%.17g\n", result);
    release(c);
    return 0;
}
