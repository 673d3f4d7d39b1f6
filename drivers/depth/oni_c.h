/* oni_c.h - OpenNI2's C headers made usable from C: OniCTypes.h names the handle types
 * _OniDevice, _OniStream and _OniRecorder without declaring them (C++ accepts that, C does not),
 * so they are declared here, as incomplete structs, before the include. */
#ifndef MESHSTEER_DRIVERS_DEPTH_ONI_C_H
#define MESHSTEER_DRIVERS_DEPTH_ONI_C_H

typedef struct _OniDevice _OniDevice;
typedef struct _OniStream _OniStream;
typedef struct _OniRecorder _OniRecorder;

#include <OniCAPI.h>

#endif
