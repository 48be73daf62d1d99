// Where a bdpt sample's two subpaths live, for subpath.glsl (which writes them through CAM(i) /
// LGT(i) indices into `vtx`) and connect.glsl (which reads vertex i of either through CAMV(i) /
// LGTV(i)):
//   - per-pixel design (default): both in one private array, camera first, then light;
//   - split design, light pass (BDPT_LIGHT_PASS): the light subpath alone in `vtx`; the camera
//     side is only the fresh lens point light tracing makes, so CAMV is a blank camera vertex;
//   - split design, camera pass (BDPT_CAMERA_PASS): the camera subpath alone in `vtx`; the light
//     vertices come from the light pass's buffer (store.glsl).
#ifndef BDPT_PATHS_GLSL
#define BDPT_PATHS_GLSL
#include "bdpt/vertex.glsl"

#if defined(BDPT_LIGHT_PASS)
#define CAM(i) 0
#define LGT(i) (i)
Vertex vtx[BDPT_MAX_LIGHT];
#define CAMV(i) vertex_blank(VTX_CAMERA)
#define LGTV(i) vtx[LGT(i)]
#elif defined(BDPT_CAMERA_PASS)
#include "bdpt/store.glsl"
#define CAM(i) (i)
#define LGT(i) 0
Vertex vtx[BDPT_MAX_CAM];
#define CAMV(i) vtx[CAM(i)]
#define LGTV(i) light_vertex_load(i)
#else
#define CAM(i) (i)
#define LGT(i) (BDPT_MAX_CAM + (i))
Vertex vtx[BDPT_MAX_CAM + BDPT_MAX_LIGHT];
#define CAMV(i) vtx[CAM(i)]
#define LGTV(i) vtx[LGT(i)]
#endif

#endif
