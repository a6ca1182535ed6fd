// Closing an OpenNI2 device and its streams in the one order that keeps clear of two races in
// OpenNI2's file player (libOniFile, OpenNI2 2.2.0.33 as Debian 12 ships it). OpenNI.h only, so
// that the test program which knows nothing else of transient (tests/openni2/
// openni_only_reader.cc) closes a recording as transientd's openni2: source does. Line numbers
// are those of OpenNI/OpenNI2 at 2.2.0.33 (Source/Drivers/OniFile, Source/Core); the crashes are
// in openni2/README.md.
//
// - Closing the device while a stream lives: Device::close deletes the core's sensors
//   (OniDevice.cpp:80-87) before the file driver joins its player thread (PlayerDevice.cpp:
//   187-190), and a frame that thread is delivering still uses its sensor (PlayerStream.cpp:
//   233-234). So the streams are destroyed first: a stream's destruction unregisters it from the
//   player's new-data event (PlayerStream.cpp:71), which waits for a delivery in flight.
// - Destroying a stream while the player walks its streams: PlayerDevice::destroyStream unlinks
//   and frees the stream without the player's lock (PlayerDevice.cpp:315-316), and the player's
//   loop walks that list without it (MainLoop, :535-543): once a file without repeat has ended,
//   continuously while any stream is started (its reads fail at once). So the streams are
//   stopped first, and a file's player is given kPlayerSettle to see it: then it walks the list
//   once each 10 ms sleep. (Before a manual-mode file's end the player instead waits for the
//   next read in OnNodeNewData, :1006, and walks the list there once each 2 s wait.) No public
//   call takes the player's lock, so this makes the race unlikely, not impossible (openni2/
//   README.md has the rates).
#pragma once

#include <OpenNI.h>

#include <chrono>
#include <initializer_list>
#include <thread>

namespace transient::openni2 {

// Time for a file's player thread to see that no stream is started (its loop sleeps 10 ms at a
// time then), with room for a busy machine's scheduling.
inline constexpr std::chrono::milliseconds kPlayerSettle{50};

// Stops every valid stream of `streams`, lets a file's player settle, destroys them, then closes
// `device`. Streams not created (or already destroyed) are skipped.
inline void CloseDevice(openni::Device& device,
                        std::initializer_list<openni::VideoStream*> streams) {
  for (openni::VideoStream* stream : streams) {
    if (stream->isValid()) stream->stop();
  }
  if (device.isValid() && device.isFile()) std::this_thread::sleep_for(kPlayerSettle);
  for (openni::VideoStream* stream : streams) stream->destroy();
  device.close();
}

}  // namespace transient::openni2
