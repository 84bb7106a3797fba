#version 430
// Meshes arrive in world space (transformed once in numpy, shared with the reference).
in vec3 in_position;
in vec3 in_normal;
uniform mat4 view_proj;
out vec3 v_position;
out vec3 v_normal;
#ifdef REFLECTION_PER_VERTEX
// realtime.reflection = "per_vertex": the mirror direction computed at the vertices and interpolated
// across each triangle (the fixed-function way), instead of per pixel from the interpolated normal.
uniform vec3 camera_position;
out vec3 v_reflect;
#endif
// the chosen techniques' vertex GLSL (realtime.engine.gpu.shading_sources): each a `void f()` run per vertex
// @techniques
void main() {
    v_position = in_position;
    // @vertex entries
    v_normal = in_normal;
#ifdef REFLECTION_PER_VERTEX
    float len = length(in_normal);
    vec3 n = len > 0.0 ? in_normal / len : vec3(0.0, 1.0, 0.0);
    v_reflect = reflect(-normalize(camera_position - in_position), n);
#endif
    gl_Position = view_proj * vec4(in_position, 1.0);
}
