/* mosyn C ABI: a crowd of characters generated frame by frame by a trained mosyn model, for game
 * engines and any language with a C foreign-function interface (Unity P/Invoke, Unreal, Godot
 * GDExtension, Python ctypes, Rust, ...). See include/README.md.
 *
 * Conventions
 * - Every function that can fail returns a mosyn_status; on failure mosyn_last_error() gives the
 *   message (file:line: what) for the calling thread. No C++ exception crosses this boundary.
 * - Handles are opaque. One crowd may be used from one thread at a time; different crowds are
 *   independent.
 * - Units: positions in the model skeleton's units (mosyn_crowd_meters_per_unit converts), angles
 *   in radians, the skeleton's axes (BVH: y up). Quaternions are (w, x, y, z), unit length, the
 *   joint's rotation relative to its parent joint (the root's: relative to the world).
 * - A game steers a character as a stick does (mosyn_crowd_step_stick): 3 floats per character
 *   and frame, the ground velocity it should reach, vx and vz in metres per second in the world
 *   (the frame of mosyn_crowd_root's floor position: heading 0 faces +z, positive headings turn
 *   towards +x), and the heading it should face, radians. Springs carry the character's root there
 *   as the training data's roots start, stop and turn (about 1.3 s from rest to full speed for the
 *   shipped models), and a model that reads the path ahead (models/moglow-realtime) reads where
 *   those springs will take the root over the next second if the stick stays: no latency, no
 *   future input. Zero velocity stands still.
 * - Offline input (a recorded path) can instead be given as a control (mosyn_crowd_step): 3 floats
 *   per character and frame, dx (sideways), dz (forward) in metres and dtheta (turn, radians), the
 *   motion of the character's floor root from the previous frame to the new one, in the character's
 *   own frame. Walking 1.2 m/s at 20 fps: {0, 0.06, 0}.
 *
 * A game loop (models/moglow-realtime, one character steered by a stick):
 *
 *   mosyn_crowd* crowd = NULL;
 *   if (mosyn_crowd_create("models/moglow-realtime", NULL, &crowd) != MOSYN_OK) {
 *     fprintf(stderr, "%s\n", mosyn_last_error());
 *     return 1;
 *   }
 *   mosyn_crowd_add(crowd, 0, NULL);
 *   const int32_t joints = mosyn_crowd_joint_count(crowd);
 *   float* rotations = malloc(sizeof(float) * 4 * joints);
 *   float sticks[16 * 3] = {0}; // capacity (default 16) x (vx, vz, facing)
 *   for (;;) {                  // once every 1 / mosyn_crowd_fps(crowd) seconds
 *     float stick_x = ..., stick_y = ..., camera_yaw = ...;   // the player's input
 *     sticks[0] = 1.5f * (stick_x * cosf(camera_yaw) + stick_y * sinf(camera_yaw)); // m/s
 *     sticks[1] = 1.5f * (stick_y * cosf(camera_yaw) - stick_x * sinf(camera_yaw));
 *     if (stick_x != 0 || stick_y != 0) sticks[2] = atan2f(sticks[0], sticks[1]); // face the way
 *     mosyn_crowd_step_stick(crowd, sticks, 16 * 3);
 *     float hips[3], floor[3], heading;
 *     mosyn_crowd_root(crowd, 0, hips, floor, &heading);
 *     mosyn_crowd_joint_rotations(crowd, 0, rotations, 4 * (size_t)joints);
 *     ... pose the engine's skeleton: joint j's local rotation rotations[4j..4j+3] (w, x, y, z),
 *         the root joint at hips (skeleton units; mosyn_crowd_meters_per_unit converts) ...
 *   }
 *   free(rotations);
 *   mosyn_crowd_destroy(crowd);
 */
#ifndef MOSYN_H
#define MOSYN_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#  if defined(MOSYN_C_BUILD)
#    define MOSYN_API __declspec(dllexport)
#  else
#    define MOSYN_API __declspec(dllimport)
#  endif
#else
#  define MOSYN_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef enum mosyn_status {
  MOSYN_OK = 0,
  MOSYN_INVALID_ARGUMENT = 1, /* NULL handle or pointer, slot or joint out of range, wrong size */
  MOSYN_RUNTIME_ERROR = 2,    /* the model could not be loaded or run */
  MOSYN_OUT_OF_MEMORY = 3
} mosyn_status;

/* The message of the last failed call on this thread ("" when none). Valid until the next call
 * into mosyn on this thread. */
MOSYN_API const char* mosyn_last_error(void);

/* Library version, "major.minor.patch". */
MOSYN_API const char* mosyn_version(void);

typedef struct mosyn_crowd mosyn_crowd;

typedef struct mosyn_crowd_options {
  int32_t capacity;           /* slots: characters stepping together (default 16) */
  int32_t threads;            /* CPU threads of the process's LibTorch, 0 = all cores (default 0) */
  uint64_t seed;              /* seeds slots filled by mosyn_crowd_add with seed 0 (default 0) */
  double temperature;         /* latent standard deviation multiplier, 1 = the model (default 1) */
  int32_t warmup_frames;      /* standing frames generated and dropped when a character is added;
                                 -1 = the model's default (MoGlow: 1 s) */
  double control_smoothing_s; /* live control shaping, < 0 = the model's dataset default, 0 = off */
} mosyn_crowd_options;

/* Fills options with the defaults above. */
MOSYN_API void mosyn_crowd_options_default(mosyn_crowd_options* options);

/* Loads a model directory (a run or a shipped model, e.g. models/moglow-realtime) into a crowd
 * of options->capacity empty slots (options NULL = defaults). *out is NULL on failure. */
MOSYN_API mosyn_status mosyn_crowd_create(const char* model_dir, const mosyn_crowd_options* options,
                                          mosyn_crowd** out);
/* Frees a crowd; NULL is ignored. */
MOSYN_API void mosyn_crowd_destroy(mosyn_crowd* crowd);

/* The skeleton and model. Functions returning a number return -1 (or 0 for fps) on a bad handle or
 * index; name functions return NULL. Strings live as long as the crowd. */
MOSYN_API int32_t mosyn_crowd_capacity(const mosyn_crowd* crowd);
MOSYN_API int32_t mosyn_crowd_joint_count(const mosyn_crowd* crowd);
MOSYN_API const char* mosyn_crowd_joint_name(const mosyn_crowd* crowd, int32_t joint);
MOSYN_API int32_t mosyn_crowd_joint_parent(const mosyn_crowd* crowd, int32_t joint); /* -1 for the root */
/* Rest offset of a joint from its parent, skeleton units, into out_xyz[3]. */
MOSYN_API mosyn_status mosyn_crowd_joint_offset(const mosyn_crowd* crowd, int32_t joint, float* out_xyz);
MOSYN_API double mosyn_crowd_fps(const mosyn_crowd* crowd);            /* frames per second of step */
MOSYN_API double mosyn_crowd_meters_per_unit(const mosyn_crowd* crowd); /* skeleton unit in metres */
/* Plays every slot on a rig instead of the model's skeleton, as `mosyn retarget` does (joints
 * paired by name, rest poses aligned in world space, path scaled by leg length; feet are not
 * planted): rig_path is a .bvh, .glb or .gltf file, NULL returns to the model's skeleton. The joint
 * functions above then describe the rig, and mosyn_crowd_joint_rotations / mosyn_crowd_root give
 * its pose in its units (the root joint carries the path). Needs an active slot: its current
 * pose aligns the model's skeleton with the rig. */
MOSYN_API mosyn_status mosyn_crowd_set_rig(mosyn_crowd* crowd, const char* rig_path);
/* Index of a label name in the model's vocabulary; kind is "content" or "style". -1 when the model
 * has no such label (or takes no labels). */
MOSYN_API int32_t mosyn_crowd_label(const mosyn_crowd* crowd, const char* kind, const char* name);

typedef struct mosyn_character {
  uint64_t seed;   /* its motion: same seed, labels and controls give the same motion */
  int32_t content; /* label index (mosyn_crowd_label), -1 = none */
  int32_t style;   /* label index, -1 = none */
} mosyn_character;

/* Starts a character in `slot` (0 <= slot < capacity), replacing whoever was there, at the world
 * origin facing +z. Its motion depends only on its own seed, labels and controls, never on the
 * other slots. character NULL = seed from the options, no labels. */
MOSYN_API mosyn_status mosyn_crowd_add(mosyn_crowd* crowd, int32_t slot, const mosyn_character* character);
/* Frees a slot: it stands still and its joint transforms are the rest pose until added again. */
MOSYN_API mosyn_status mosyn_crowd_remove(mosyn_crowd* crowd, int32_t slot);
/* 1 when the slot holds a character, 0 when free, -1 on a bad handle or slot. */
MOSYN_API int32_t mosyn_crowd_active(const mosyn_crowd* crowd, int32_t slot);

/* Advances every slot by one frame. controls: capacity x 3 floats (see the conventions above;
 * free slots' entries are ignored), count = their number. */
MOSYN_API mosyn_status mosyn_crowd_step(mosyn_crowd* crowd, const float* controls, size_t count);

/* Advances every slot by one frame steered by a stick. sticks: capacity x 3 floats, per slot the
 * ground velocity to reach (vx, vz, m/s, world) and the heading to face (radians), see the
 * conventions above; free slots' entries are ignored; count = their number. Frame t depends on
 * the sticks up to t only. Steps by stick and by control may alternate. */
MOSYN_API mosyn_status mosyn_crowd_step_stick(mosyn_crowd* crowd, const float* sticks, size_t count);

/* Pose of a slot after the last step: out_wxyz receives joint_count x 4 floats (count = their
 * number, at least 4 x joint_count), each joint's local rotation. */
MOSYN_API mosyn_status mosyn_crowd_joint_rotations(const mosyn_crowd* crowd, int32_t slot, float* out_wxyz,
                                                   size_t count);
/* Root of a slot after the last step: the root joint's translation in the world (out_translation,
 * 3 floats, skeleton units; NULL to skip), and the character's floor position (out_floor, 3 floats,
 * skeleton units; NULL to skip) and heading about the up axis (out_heading_rad; NULL to skip). */
MOSYN_API mosyn_status mosyn_crowd_root(const mosyn_crowd* crowd, int32_t slot, float* out_translation,
                                        float* out_floor, float* out_heading_rad);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* MOSYN_H */
