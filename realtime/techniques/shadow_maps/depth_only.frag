#version 430
// Depth only: no colour is written.
void main() {}
