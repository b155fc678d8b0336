//! Uploads a scene's images as sampled Vulkan images.
