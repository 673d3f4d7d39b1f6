/* record.h - --record: keeps the incoming marker stream and writes it as a C3D file at the end,
 * so that `replay:` plays it back identically (same markers, names, fps; invalid samples stay
 * invalid). Storage grows geometrically (amortised, not per frame) from the source thread. */
#ifndef MESHSTEER_SERVER_RECORD_H
#define MESHSTEER_SERVER_RECORD_H

#include <stdint.h>

typedef struct srv_recorder srv_recorder;

int srv_recorder_create(const char *path, int count, const char *const *names, double fps,
                        srv_recorder **out, char *err);
/* Appends one frame (count x 3 metres, count validity flags). -ENOMEM when memory runs out; the
 * recording then stops growing and says so when written. */
int srv_recorder_add(srv_recorder *r, const float *xyz, const uint8_t *valid);
int srv_recorder_frames(const srv_recorder *r);
int srv_recorder_write(srv_recorder *r, char *err);
void srv_recorder_destroy(srv_recorder *r);

#endif
