/* refrender dataset: runs scripts/dataset.py (PNG, npy and JSON are the
 * scripts' trade; the renders it makes are this binary's), so that the user
 * types `refrender dataset ...` whatever the script's place. */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd/cli.h"
#include "cmd/commands.h"

/* Debian's interpreter, which every script names (#!/usr/bin/python3) and
 * scripts/install-deps.sh gives numpy and OpenImageIO */
#ifndef RR_PYTHON
#define RR_PYTHON "/usr/bin/python3"
#endif

/* This executable's path, or 0 on failure. */
static int self_path(char *exe, size_t size)
{
    ssize_t n = readlink("/proc/self/exe", exe, size - 1);
    if (n <= 0 || (size_t)n >= size - 1)
        return 0;
    exe[n] = 0;
    return 1;
}

int cmd_dataset(int argc, char **argv)
{
    char exe[PATH_MAX], script[PATH_MAX + 64];
    if (!self_path(exe, sizeof exe)) {
        fprintf(stderr, "refrender dataset: cannot find this executable's path (/proc/self/exe)\n");
        return 1;
    }
    /* beside the executable's tree, then in the source tree, as the default scene */
    const char *path = cli_tree_file("scripts/dataset.py", script, sizeof script);
    if (access(path, R_OK)) {
        fprintf(stderr, "refrender dataset: scripts/dataset.py found neither beside %s's tree nor as %s\n", exe,
                path);
        return 1;
    }
    /* the renders are this binary's, whatever REFRENDER says */
    if (setenv("REFRENDER", exe, 1)) {
        fprintf(stderr, "refrender dataset: setenv: %s\n", strerror(errno));
        return 1;
    }
    char **args = calloc((size_t)argc + 2, sizeof *args);
    if (!args) {
        fprintf(stderr, "refrender dataset: out of memory\n");
        return 1;
    }
    args[0] = RR_PYTHON;
    args[1] = (char *)path;
    for (int i = 1; i < argc; i++) /* argv[0] is "dataset" */
        args[i + 1] = argv[i];
    execv(RR_PYTHON, args);
    fprintf(stderr, "refrender dataset: cannot run %s: %s (scripts/install-deps.sh installs it)\n", RR_PYTHON,
            strerror(errno));
    free(args);
    return 1;
}
