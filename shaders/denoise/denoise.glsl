// Denoising (SVGF, Schied et al. 2017), the parts its passes share: the uniform, the buffers
// it reaches by address, and the demodulated illumination of a pixel.
// Each pixel's colour splits into three (DenoiseGuide, written by the distributed shading
// passes): light through the first vertex's diffuse lobe; the rest of its reflected light
// (specular); and what needs no filter (emission, misses). The two reflected parts are
// accumulated over frames, divided by their accumulated albedos (diffuse and specular
// illumination), filtered apart, then multiplied back by the albedos
// (denoise_remodulate.comp).
#ifndef RQR_DENOISE_GLSL
#define RQR_DENOISE_GLSL
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "interface_passes.glsl"
#include "interface_denoise.glsl"

layout(set = 0, binding = BINDING_DENOISE_PARAMS, scalar) uniform Params { DenoiseParams params; };

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Vec4s { vec4 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Guides { DenoiseGuide v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Aovs { Aov v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Surfaces { DenoiseSurface v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Moments { DenoiseMoments v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer Histories { DenoiseHistory v[]; };

// The edge texel's w bits on a miss.
const uint EDGE_MISS = 0xFFFFFFFFu;

// Octahedral encoding of a unit normal (Cigolle et al. 2014) into two snorm16.
uint encode_normal(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return packSnorm2x16(e);
}

vec3 decode_normal(uint bits) {
    vec2 e = unpackSnorm2x16(bits);
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

// Albedos are clamped away from 0 so that a black surface divides and multiplies back exactly.
const float MIN_ALBEDO = 1e-3;

float luma(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

bool inside(ivec2 p) { return p.x >= 0 && p.y >= 0 && p.x < int(params.width) && p.y < int(params.height); }
uint pixel_index(ivec2 p) { return uint(p.y) * params.width + uint(p.x); }

bool pixel_hit(uint i) { return Aovs(params.aov).v[i].instance != AOV_NO_ID; }

// The pixel's diffuse and specular reflected light this frame (its own samples).
void reflected(uint i, out vec3 diffuse, out vec3 specular) {
    vec4 c = Vec4s(params.color).v[i];
    vec3 color = (params.flags & DN_WEIGHTED_COLOR) != 0u ? (c.a > 0.0 ? c.rgb / c.a : vec3(0.0)) : c.rgb;
    DenoiseGuide g = Guides(params.guide).v[i];
    float w = g.diffuse.a > 0.0 ? g.diffuse.a : 1.0;
    diffuse = g.diffuse.rgb / w;
    specular = max(color - diffuse - g.unfiltered.rgb / w, vec3(0.0));
}

// 2 vec4 per pixel (diffuse, specular) in the buffer at `address`.
vec4 pair_load(uint64_t address, uint i, uint which) { return Vec4s(address).v[2u * i + which]; }
void pair_store(uint64_t address, uint i, vec4 d, vec4 s) {
    Vec4s(address).v[2u * i] = d;
    Vec4s(address).v[2u * i + 1u] = s;
}

#endif
