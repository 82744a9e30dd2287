"""IFC → SDF converter: split IFC, meshes, model folders, world, manifest, sequence."""
