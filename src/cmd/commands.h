/* The refrender subcommands (src/cmd/): each parses its own arguments and
 * returns the process exit status. */
#ifndef RR_COMMANDS_H
#define RR_COMMANDS_H

#include <stdio.h>

int cmd_render(int argc, char **argv);
/* The program's usage (main.c): the render command's options and the subcommands. */
void refrender_usage(FILE *f);
int cmd_gen(int argc, char **argv);
int cmd_merge(int argc, char **argv);
int cmd_surfels(int argc, char **argv);
int cmd_export(int argc, char **argv);
int cmd_splat(int argc, char **argv);
int cmd_dataset(int argc, char **argv);

#endif
