#include "hal/d455/record_euroc.hpp"

#include "hal/replay/euroc_writer.hpp"

namespace ums::d455 {

Status record_euroc(D455Device& device, const RigCalibration& calibration, const std::string& out_dir,
                    const RecordOptions& options, const std::atomic<bool>* stop, RecordSummary* summary,
                    std::string* error) {
  hal::EurocWriter writer;
  writer.open(out_dir, calibration);
  const Status status = record(device, writer, options, stop, summary, error);
  writer.close();  // throws with the writer's message if any write failed
  return status;
}

}  // namespace ums::d455
