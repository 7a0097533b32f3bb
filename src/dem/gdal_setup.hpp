#pragma once
// GDAL's process-wide set-up, done once before any GDAL call.
namespace terrabake::dem {
// Registers drivers and routes GDAL's messages to our log instead of stderr,
// so that errors reach the user once, as our own one-line messages.
void ensureGdalReady();
}  // namespace terrabake::dem
