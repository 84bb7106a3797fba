"""The scene in other tools' formats: `iblcheck export` (glTF 2.0, the environment as a viewer's equirect
.hdr, a JSON sidecar with what glTF cannot say) and glTF Render Fidelity scenarios, written and read."""
