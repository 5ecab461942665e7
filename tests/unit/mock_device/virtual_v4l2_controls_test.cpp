// The virtual camera's controls on their own: v4l2-ctrls.c's rules (step rounding and
// clamping, menu holes, error_idx, the NEXT_CTRL walk), the latency in frames of a value
// set while streaming, and the changes reported for control events.
#include "mock_device/v4l2/virtual_v4l2_controls.h"

#include <gtest/gtest.h>

#include <tuple>
#include <vector>

namespace camlab::mock {
namespace {

ControlsSpec test_controls() {
  ControlsSpec spec;
  spec.gain = {.min = 100, .max = 1600, .step = 10, .default_value = 100};
  spec.exposure_time_absolute = {.min = 0, .max = 95, .step = 10, .default_value = 50};
  spec.focus_absolute = {.min = 0, .max = 2000, .step = 1, .default_value = 0};
  spec.iris_absolute = {.min = 0, .max = 5, .step = 1, .default_value = 0};
  return spec;
}

struct Change {
  uint32_t id;
  uint32_t changes;
  bool by_caller;
  bool operator==(const Change&) const = default;
};

class VirtualV4l2ControlsTest : public ::testing::Test {
 protected:
  // S_EXT_CTRLS of one control; the value as set, or the error.
  int set(uint32_t id, int32_t value, std::optional<uint64_t> next_frame = std::nullopt) {
    v4l2_ext_control ext{};
    ext.id = id;
    ext.value = value;
    v4l2_ext_controls request{};
    request.which = V4L2_CTRL_WHICH_CUR_VAL;
    request.count = 1;
    request.controls = &ext;
    const int error = controls.set(&request, next_frame, [&](uint32_t i, uint32_t c, bool by) {
      changes.push_back({i, c, by});
    });
    return error < 0 ? error : ext.value;
  }

  VirtualV4l2Controls controls{test_controls(), 2};
  std::vector<Change> changes;
};

TEST_F(VirtualV4l2ControlsTest, IntegersRoundOntoTheirStepAndClampToTheRange) {
  EXPECT_EQ(set(V4L2_CID_GAIN, 104), 100);
  EXPECT_EQ(set(V4L2_CID_GAIN, 105), 110);  // half a step rounds up
  EXPECT_EQ(set(V4L2_CID_GAIN, 2000), 1600);
  EXPECT_EQ(set(V4L2_CID_GAIN, -5), 100);
  // A maximum off the step grid stays reachable, and is never exceeded.
  EXPECT_EQ(set(V4L2_CID_EXPOSURE_ABSOLUTE, 94), 90);
  EXPECT_EQ(set(V4L2_CID_EXPOSURE_ABSOLUTE, 95), 95);
  EXPECT_EQ(set(V4L2_CID_FOCUS_AUTO, 7), 1);  // booleans are 0 or 1
}

TEST_F(VirtualV4l2ControlsTest, ValuesSetWhileStreamingReachTheSensorAfterTheLatency) {
  EXPECT_EQ(set(V4L2_CID_GAIN, 400), 400);  // no stream: at once
  EXPECT_EQ(controls.in_effect(V4L2_CID_GAIN), 400);

  EXPECT_EQ(set(V4L2_CID_GAIN, 800, 5), 800);  // frame 5 starts next; latency 2
  EXPECT_EQ(controls.in_effect(V4L2_CID_GAIN), 400);
  controls.apply_due(5);
  controls.apply_due(6);
  EXPECT_EQ(controls.in_effect(V4L2_CID_GAIN), 400);
  controls.apply_due(7);
  EXPECT_EQ(controls.in_effect(V4L2_CID_GAIN), 800);

  // Stopping the stream applies whatever is still on its way.
  EXPECT_EQ(set(V4L2_CID_GAIN, 1200, 8), 1200);
  controls.apply_pending();
  EXPECT_EQ(controls.in_effect(V4L2_CID_GAIN), 1200);
  controls.apply_due(100);
  EXPECT_EQ(controls.in_effect(V4L2_CID_GAIN), 1200);
}

TEST_F(VirtualV4l2ControlsTest, MenusRejectValuesOutsideAndHolesInside) {
  EXPECT_EQ(set(V4L2_CID_EXPOSURE_AUTO, 0), -ERANGE);
  EXPECT_EQ(set(V4L2_CID_EXPOSURE_AUTO, 2), -EINVAL);  // V4L2_EXPOSURE_SHUTTER_PRIORITY
  EXPECT_EQ(set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_APERTURE_PRIORITY),
            V4L2_EXPOSURE_APERTURE_PRIORITY);

  v4l2_querymenu item{};
  item.id = V4L2_CID_EXPOSURE_AUTO;
  item.index = 2;
  EXPECT_EQ(controls.querymenu(&item), -EINVAL);
  item.index = 1;
  ASSERT_EQ(controls.querymenu(&item), 0);
  EXPECT_STREQ(reinterpret_cast<const char*>(item.name), "Manual Mode");
}

TEST_F(VirtualV4l2ControlsTest, ErrorIndexIsCountForSetAndTheControlForTry) {
  v4l2_ext_control ext[2]{};
  ext[0].id = V4L2_CID_GAIN;
  ext[0].value = 300;
  ext[1].id = V4L2_CID_EXPOSURE_AUTO;
  ext[1].value = 2;  // a hole
  v4l2_ext_controls request{};
  request.which = V4L2_CTRL_WHICH_CUR_VAL;
  request.count = 2;
  request.controls = ext;
  EXPECT_EQ(controls.try_set(&request), -EINVAL);
  EXPECT_EQ(request.error_idx, 1u);
  EXPECT_EQ(controls.set(&request, std::nullopt, [](uint32_t, uint32_t, bool) {}), -EINVAL);
  EXPECT_EQ(request.error_idx, 2u);
  EXPECT_EQ(controls.find(V4L2_CID_GAIN)->value, 100);  // all or nothing

  // A control class is write-only: G_EXT_CTRLS reads nothing and says count.
  ext[1].id = V4L2_CID_CAMERA_CLASS;
  EXPECT_EQ(controls.get(&request), -EACCES);
  EXPECT_EQ(request.error_idx, 2u);
}

TEST_F(VirtualV4l2ControlsTest, RequestChecksComeFirst) {
  v4l2_ext_controls request{};
  request.which = V4L2_CTRL_WHICH_CUR_VAL;
  request.count = 1;
  EXPECT_EQ(controls.check_request(VIDIOC_S_EXT_CTRLS, request), -EFAULT);  // no array
  request.count = 1025;
  EXPECT_EQ(controls.check_request(VIDIOC_G_EXT_CTRLS, request), -EINVAL);
  request.count = 0;
  request.which = V4L2_CTRL_WHICH_DEF_VAL;
  EXPECT_EQ(controls.check_request(VIDIOC_G_EXT_CTRLS, request), 0);
  EXPECT_EQ(controls.check_request(VIDIOC_S_EXT_CTRLS, request), -EINVAL);
  EXPECT_EQ(controls.check_request(VIDIOC_TRY_EXT_CTRLS, request), -EINVAL);

  // Defaults are read with DEF_VAL, whatever the current value.
  ASSERT_EQ(set(V4L2_CID_GAIN, 500), 500);
  v4l2_ext_control ext{};
  ext.id = V4L2_CID_GAIN;
  request.count = 1;
  request.controls = &ext;
  ASSERT_EQ(controls.get(&request), 0);
  EXPECT_EQ(ext.value, 100);
}

TEST_F(VirtualV4l2ControlsTest, AutoModesReportTheirManualControlInactive) {
  ASSERT_EQ(set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_APERTURE_PRIORITY),
            V4L2_EXPOSURE_APERTURE_PRIORITY);
  EXPECT_EQ(changes,
            (std::vector<Change>{{V4L2_CID_EXPOSURE_AUTO, V4L2_EVENT_CTRL_CH_VALUE, true},
                                 {V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_EVENT_CTRL_CH_FLAGS, false}}));
  EXPECT_TRUE(controls.find(V4L2_CID_EXPOSURE_ABSOLUTE)->query.flags & V4L2_CTRL_FLAG_INACTIVE);
  const v4l2_event event = controls.event(V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_EVENT_CTRL_CH_FLAGS);
  EXPECT_EQ(event.type, V4L2_EVENT_CTRL);
  EXPECT_TRUE(event.u.ctrl.flags & V4L2_CTRL_FLAG_INACTIVE);
  EXPECT_EQ(event.u.ctrl.value64, 50);

  changes.clear();
  ASSERT_EQ(set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_APERTURE_PRIORITY),
            V4L2_EXPOSURE_APERTURE_PRIORITY);
  EXPECT_TRUE(changes.empty());  // the same value again changes nothing
}

TEST_F(VirtualV4l2ControlsTest, NextCtrlWalksEveryControlInIdOrder) {
  std::vector<uint32_t> ids;
  v4l2_query_ext_ctrl query{};
  query.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  while (controls.query_ext_ctrl(&query) == 0) {
    ids.push_back(query.id);
    query.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  EXPECT_EQ(ids, (std::vector<uint32_t>{V4L2_CID_USER_CLASS, V4L2_CID_GAIN, V4L2_CID_CAMERA_CLASS,
                                        V4L2_CID_EXPOSURE_AUTO, V4L2_CID_EXPOSURE_ABSOLUTE,
                                        V4L2_CID_FOCUS_ABSOLUTE, V4L2_CID_FOCUS_AUTO,
                                        V4L2_CID_IRIS_ABSOLUTE}));
  query.id = V4L2_CTRL_FLAG_NEXT_COMPOUND;  // every control here is a plain one
  EXPECT_EQ(controls.query_ext_ctrl(&query), -EINVAL);

  v4l2_queryctrl old{};
  old.id = V4L2_CID_GAIN;
  ASSERT_EQ(controls.queryctrl(&old), 0);
  EXPECT_STREQ(reinterpret_cast<const char*>(old.name), "Gain");
  EXPECT_EQ(old.step, 10);
}

}  // namespace
}  // namespace camlab::mock
