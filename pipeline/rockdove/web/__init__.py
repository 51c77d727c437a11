"""The asset on the web: glTF 2.0 export (:mod:`.gltf`), the offline three.js viewer page (:mod:`.viewer`) and a
headless Chromium driver (:mod:`.browser`) that the web host and the tests use."""
