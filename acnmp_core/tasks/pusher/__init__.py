"""The MuJoCo Pusher task (Gymnasium ``Pusher-v5``): the scene, its gains and its demonstrations."""
