// variants: hw bvh
#version 460
// Hybrid shading pass in the distributed model, reading the full G-buffer; see hybrid_main.glsl.
#extension GL_GOOGLE_include_directive : require
#define SHADING_DISTRIBUTED 1
#include "hybrid_main.glsl"
