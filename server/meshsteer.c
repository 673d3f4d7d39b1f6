/* meshsteer.c - the command-line tool: train, synth, eval, inspect, render, bench, example.
 * Each command lives in its own cmd_*.c file; this file only dispatches. */
#include "cli.h"

#include <stdio.h>
#include <string.h>

/* model commands (cmd_train.c, cmd_synth.c, cmd_eval.c, cmd_inspect.c, cmd_bench.c, cmd_demo.c) */
int cmd_train(int argc, char **argv);
int cmd_synth(int argc, char **argv);
int cmd_eval(int argc, char **argv);
int cmd_inspect(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_demo(int argc, char **argv);
int cmd_markers(int argc, char **argv);
int cmd_rig(int argc, char **argv); /* cmd_rig.c */
int cmd_skin(int argc, char **argv); /* cmd_skin.c */
int cmd_variations(int argc, char **argv); /* cmd_variations.c */

/* render and example commands (cmd_render.c, cmd_example.c) */

/* depth commands (cmd_depth_eval.c) */
int cmd_depth_eval(int argc, char **argv);
int cmd_kinect(int argc, char **argv); /* cmd_kinect.c */
int cmd_render(int argc, char **argv);
int cmd_example(int argc, char **argv);
/* recordings (cmd_record.c, cmd_osc_play.c) */
int cmd_record(int argc, char **argv);
int cmd_osc_play(int argc, char **argv);

static const cli_command commands[] = {
    /* model commands */
    {"demo", "train on the built-in example and synthesise its recording", cmd_demo},
    {"train", "learn a model from a mesh sequence and a rig", cmd_train},
    {"synth", "drive a model with a marker recording, write PC2/OBJ", cmd_synth},
    {"eval", "measure a model against ground-truth frames (JSON)", cmd_eval},
    {"inspect", "summarise a model file", cmd_inspect},
    {"skin", "decompose a mesh animation into a skin with rigid bones (SSDR), glTF export", cmd_skin},
    {"variations", "many different animations of any length from a skin's example (PC2)", cmd_variations},
    {"bench", "time training and per-frame synthesis (median, p99)", cmd_bench},
    {"markers", "write the rig vertices of a mesh sequence as a marker file", cmd_markers},
    {"rig", "propose a rig (markers, reference, limbs) from the mesh alone", cmd_rig},

    /* render and example commands */
    {"render", "draw a contact sheet (PNG) of mesh frames", cmd_render},
    {"example", "write the built-in example creature, rig and markers", cmd_example},

    /* depth commands */
    {"depth-eval", "score depth->markers on a mesh sequence seen by the test camera", cmd_depth_eval},
    {"kinect", "Kinect v1 tilt and LED; list or watch depth sensors on USB", cmd_kinect},

    /* recordings */
    {"record", "make a recording of recordings/ (markers, OSC, depth, .oni) from the example", cmd_record},
    {"osc-play", "send an OSC capture to a UDP port at its recorded times", cmd_osc_play},

    {NULL, NULL, NULL},
};

static void usage(FILE *f)
{
    fprintf(f, "usage: meshsteer COMMAND [OPTIONS]\n\n"
               "Steers detailed mesh animations from a few tracked points: a steering model learned from an\n"
               "example animation (Voegele et al. 2012), a static mesh animated by a skeleton (de Aguiar\n"
               "et al. 2007), and a skin of an animation (Le & Deng 2012).\n\n"
               "commands:\n");
    for (const cli_command *c = commands; c->name; c++)
        fprintf(f, "  %-11s %s\n", c->name, c->summary);
    fprintf(f, "\n'meshsteer COMMAND --help' describes a command's options.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return CLI_EXIT_USAGE;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return CLI_EXIT_OK;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("meshsteer %s\n", MESHSTEER_VERSION);
        return CLI_EXIT_OK;
    }
    for (const cli_command *c = commands; c->name; c++)
        if (!strcmp(argv[1], c->name))
            return c->run(argc - 1, argv + 1);
    fprintf(stderr, "meshsteer: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return CLI_EXIT_USAGE;
}
