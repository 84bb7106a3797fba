#version 430
// The depth pass of one light's shadow map: world positions through that light's orthographic view.
in vec3 in_position;
uniform mat4 light_view_proj;
void main() {
    gl_Position = light_view_proj * vec4(in_position, 1.0);
}
