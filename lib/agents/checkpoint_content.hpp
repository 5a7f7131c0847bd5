#pragma once

namespace f16race::agents {

// What an agent's checkpoint file holds: everything a resume needs, or only what acting reads
// (a shared policy, e.g. the shipped team: no optimiser state, which is about two thirds of a
// file, and for the high level no target network).
enum class CheckpointContent { kFull, kPolicy };

}  // namespace f16race::agents
