/* A crowd through the C ABI (include/mosyn.h), in plain C: eight characters in two styles walk
 * and turn for three seconds, steered by stick; prints where each ends up and the per-frame cost, and checks the
 * library's contract on the way (unit quaternions, errors reported, exact replay of a character).
 * Usage: crowd [MODEL_DIR [RIG]]   (default models/moglow-realtime). With RIG (a .bvh, .glb or .gltf
 * skeleton) the crowd then walks on that rig (mosyn_crowd_set_rig). Exit code 0 when all is well. */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mosyn.h"

#define CAPACITY 8

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int check(mosyn_status status, const char* what) {
  if (status == MOSYN_OK) return 1;
  fprintf(stderr, "crowd: %s failed (%d): %s\n", what, (int)status, mosyn_last_error());
  return 0;
}

/* Walks every slot for `frames` frames, steered as a game steers (a stick per slot: the world
 * velocity to reach and the heading to face): slot k at 0.8 + 0.1 k m/s, its facing swaying by its
 * own phase. Stores slot 0's joint rotations of the last frame in last0 (4 x joints floats). */
static int walk(mosyn_crowd* crowd, int frames, float* last0, size_t count) {
  const double fps = mosyn_crowd_fps(crowd);
  float sticks[CAPACITY * 3];
  for (int f = 0; f < frames; ++f) {
    for (int k = 0; k < CAPACITY; ++k) {
      const double speed = 0.8 + 0.1 * k, facing = 0.4 * k + 0.5 * sin(f / fps + k);
      sticks[3 * k + 0] = (float)(speed * sin(facing)); /* vx, m/s */
      sticks[3 * k + 1] = (float)(speed * cos(facing)); /* vz, m/s */
      sticks[3 * k + 2] = (float)facing;                /* heading to face, radians */
    }
    if (!check(mosyn_crowd_step_stick(crowd, sticks, CAPACITY * 3), "mosyn_crowd_step_stick")) return 0;
  }
  return check(mosyn_crowd_joint_rotations(crowd, 0, last0, count), "mosyn_crowd_joint_rotations");
}

/* The crowd played on another skeleton: the rig's joints, unit quaternions, a root that moves. */
static int walk_on_rig(mosyn_crowd* crowd, const char* rig, int frames) {
  float before[3], after[3];
  if (!check(mosyn_crowd_set_rig(crowd, rig), "mosyn_crowd_set_rig") ||
      !check(mosyn_crowd_root(crowd, 0, before, NULL, NULL), "mosyn_crowd_root"))
    return 0;
  const int joints = mosyn_crowd_joint_count(crowd);
  const size_t count = 4 * (size_t)joints;
  float* rotations = malloc(count * sizeof(float));
  int ok = rotations && walk(crowd, frames, rotations, count) &&
           check(mosyn_crowd_root(crowd, 0, after, NULL, NULL), "mosyn_crowd_root");
  for (int j = 0; ok && j < joints; ++j) {
    const float* q = rotations + 4 * j;
    if (fabs(sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) - 1.0) > 1e-4) ok = 0;
  }
  const double m = mosyn_crowd_meters_per_unit(crowd);
  const double moved = m * hypot(after[0] - before[0], after[2] - before[2]);
  if (ok && moved > 0.5)
    printf("on %s: %d joints (root %s), slot 0 walked %.2f m\n", rig, joints, mosyn_crowd_joint_name(crowd, 0), moved);
  else
    fprintf(stderr, "crowd: on the rig, slot 0 %s\n", ok ? "did not walk" : "has a bad pose");
  free(rotations);
  return ok && moved > 0.5 && check(mosyn_crowd_set_rig(crowd, NULL), "mosyn_crowd_set_rig(NULL)");
}

int main(int argc, char** argv) {
  const char* model = argc > 1 ? argv[1] : "models/moglow-realtime";
  mosyn_crowd_options options;
  mosyn_crowd_options_default(&options);
  options.capacity = CAPACITY;
  options.threads = 1;
  mosyn_crowd* crowd = NULL;
  if (!check(mosyn_crowd_create(model, &options, &crowd), "mosyn_crowd_create")) return 1;

  const int joints = mosyn_crowd_joint_count(crowd);
  const size_t count = 4 * (size_t)joints;
  float* rotations = malloc(count * sizeof(float));
  float* first = malloc(count * sizeof(float));
  int ok = rotations && first;
  const int32_t styles[2] = {mosyn_crowd_label(crowd, "style", "normal"), mosyn_crowd_label(crowd, "style", "elderly")};
  for (int k = 0; ok && k < CAPACITY; ++k) {
    mosyn_character c = {1000 + (uint64_t)k, mosyn_crowd_label(crowd, "content", "walk"), styles[k % 2]};
    ok = check(mosyn_crowd_add(crowd, k, &c), "mosyn_crowd_add");
  }

  const int frames = (int)(3 * mosyn_crowd_fps(crowd));
  const double start = now_s();
  ok = ok && walk(crowd, frames, first, count);
  const double per_frame_ms = 1000 * (now_s() - start) / frames;

  for (int k = 0; ok && k < CAPACITY; ++k) {
    float floor[3], heading;
    ok = check(mosyn_crowd_root(crowd, k, NULL, floor, &heading), "mosyn_crowd_root") &&
         check(mosyn_crowd_joint_rotations(crowd, k, rotations, count), "mosyn_crowd_joint_rotations");
    for (int j = 0; ok && j < joints; ++j) {
      const float* q = rotations + 4 * j;
      const double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (fabs(norm - 1.0) > 1e-4) {
        fprintf(stderr, "crowd: joint %s of slot %d has a quaternion of norm %g\n", mosyn_crowd_joint_name(crowd, j), k, norm);
        ok = 0;
      }
    }
    const double m = mosyn_crowd_meters_per_unit(crowd);
    if (ok) printf("slot %d: at (%.2f, %.2f) m, heading %.2f rad\n", k, floor[0] * m, floor[2] * m, heading);
  }

  /* Errors come back as statuses with a message, never as crashes. */
  if (ok && (mosyn_crowd_add(crowd, CAPACITY, NULL) != MOSYN_INVALID_ARGUMENT || strlen(mosyn_last_error()) == 0)) {
    fprintf(stderr, "crowd: a slot out of range was not reported\n");
    ok = 0;
  }

  /* Replay: slot 0 restarted with its seed and labels walks exactly the same frames again. */
  if (ok) {
    mosyn_character c = {1000, mosyn_crowd_label(crowd, "content", "walk"), styles[0]};
    ok = check(mosyn_crowd_remove(crowd, 0), "mosyn_crowd_remove") && mosyn_crowd_active(crowd, 0) == 0 &&
         check(mosyn_crowd_add(crowd, 0, &c), "mosyn_crowd_add") && walk(crowd, frames, rotations, count);
    if (ok && memcmp(first, rotations, count * sizeof(float)) != 0) {
      fprintf(stderr, "crowd: slot 0 did not replay exactly\n");
      ok = 0;
    }
  }
  if (ok) printf("%d characters, %d joints: %.2f ms per frame; replay exact\n", CAPACITY, joints, per_frame_ms);
  if (ok && argc > 2) ok = walk_on_rig(crowd, argv[2], frames);
  free(rotations);
  free(first);
  mosyn_crowd_destroy(crowd);
  return ok ? 0 : 1;
}
