"""Renderers iblcheck did not write, driven from outside: any engine as a command (`[realtime] renderer =
"command"`), and the bridges to three.js, Babylon.js (headless Chromium, engines/web/) and Blender's Cycles
(engines/cycles/). Each reads the files `iblcheck export` writes (scenes/exchange/) and returns a linear image.
A peer of realtime and groundtruth: none of the three imports another."""
