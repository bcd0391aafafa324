// The camera simulator's GenICam description (camera_registers.hpp): the
// standard feature names the driver uses, over the registers of the
// simulator's own block, written here rather than borrowed from Aravis.
#include <cctype>
#include <cstdio>
#include <sstream>
#include <string>

#include "camera_registers.hpp"
#include "chromo/drivers/camera.hpp"

namespace chromo::simulators::camera_registers {
namespace {

std::string hex(std::uint32_t value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%x", value);
  return text;
}

std::string int_reg(const std::string& name, std::uint32_t address, const char* access) {
  return "  <IntReg Name=\"" + name + "\" NameSpace=\"Custom\">\n    <Address>" + hex(address) +
         "</Address>\n    <Length>4</Length>\n    <AccessMode>" + access +
         "</AccessMode>\n    <pPort>Device</pPort>\n    <Sign>Unsigned</Sign>\n"
         "    <Endianess>BigEndian</Endianess>\n  </IntReg>\n";
}

std::string string_reg(const std::string& name, std::uint32_t address, int length, const char* access) {
  return "  <StringReg Name=\"" + name + "\" NameSpace=\"Standard\">\n    <Address>" + hex(address) +
         "</Address>\n    <Length>" + std::to_string(length) + "</Length>\n    <AccessMode>" + access +
         "</AccessMode>\n    <pPort>Device</pPort>\n  </StringReg>\n";
}

// An Integer feature over its register, with fixed or referenced limits.
std::string integer(const std::string& name, const std::string& register_name, const std::string& min,
                    const std::string& max) {
  auto limit = [](const char* tag, const std::string& value) {
    if (value.empty()) return std::string();
    const bool reference = !(value[0] >= '0' && value[0] <= '9');
    return "    <" + std::string(reference ? "p" : "") + tag + ">" + value + "</" + (reference ? "p" : "") + tag +
           ">\n";
  };
  return "  <Integer Name=\"" + name + "\" NameSpace=\"Standard\">\n    <pValue>" + register_name + "</pValue>\n" +
         limit("Min", min) + limit("Max", max) + "  </Integer>\n";
}

std::string enumeration(const std::string& name, const std::string& register_name,
                        std::initializer_list<std::pair<std::string, std::uint32_t>> entries) {
  std::string text = "  <Enumeration Name=\"" + name + "\" NameSpace=\"Standard\">\n";
  for (const auto& [entry, value] : entries)
    text += "    <EnumEntry Name=\"" + entry + "\" NameSpace=\"Standard\">\n      <Value>" + std::to_string(value) +
            "</Value>\n    </EnumEntry>\n";
  return text + "    <pValue>" + register_name + "</pValue>\n  </Enumeration>\n";
}

std::string boolean(const std::string& name, const std::string& register_name) {
  return "  <Boolean Name=\"" + name + "\" NameSpace=\"Standard\">\n    <pValue>" + register_name +
         "</pValue>\n    <OnValue>1</OnValue>\n    <OffValue>0</OffValue>\n  </Boolean>\n";
}

std::string command(const std::string& name, const std::string& register_name) {
  return "  <Command Name=\"" + name + "\" NameSpace=\"Standard\">\n    <pValue>" + register_name +
         "</pValue>\n    <CommandValue>1</CommandValue>\n  </Command>\n";
}

// A Float feature: register value × scale = feature value.
std::string scaled_float(const std::string& name, const std::string& register_name, const std::string& to_register,
                         const std::string& from_register, const char* min, const char* max, const char* unit) {
  return "  <Float Name=\"" + name + "\" NameSpace=\"Standard\">\n    <pValue>" + name + "Converter</pValue>\n" +
         "    <Min>" + min + "</Min>\n    <Max>" + max + "</Max>\n    <Unit>" + unit + "</Unit>\n  </Float>\n" +
         "  <Converter Name=\"" + name + "Converter\" NameSpace=\"Custom\">\n    <FormulaTo>" + to_register +
         "</FormulaTo>\n    <FormulaFrom>" + from_register + "</FormulaFrom>\n    <pValue>" + register_name +
         "</pValue>\n  </Converter>\n";
}

std::string category(const std::string& name, std::initializer_list<const char*> features) {
  std::string text = "  <Category Name=\"" + name + "\" NameSpace=\"Standard\">\n";
  for (const char* feature : features) text += "    <pFeature>" + std::string(feature) + "</pFeature>\n";
  return text + "  </Category>\n";
}

// The GenApi schema's name type, [A-Za-z][0-9A-Za-z_]*, which
// RegisterDescription's ModelName must be (arv-test-0.8's Genicam:Schema check
// refused "CHROMO-SIM-CAM"): other characters become '_', and a name not
// starting with a letter gets an 'M' before it. DeviceModelName keeps the
// device's own model text.
std::string genapi_name(const std::string& text) {
  std::string name;
  for (const char c : text) name += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  if (name.empty() || !std::isalpha(static_cast<unsigned char>(name.front()))) name.insert(0, "M");
  return name;
}

}  // namespace

std::string genicam_xml(const std::string& model_name) {
  std::ostringstream xml;
  xml << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
      << "<RegisterDescription ModelName=\"" << genapi_name(model_name) << "\" VendorName=\"Chromosphere\" "
      << "StandardNameSpace=\"None\" SchemaMajorVersion=\"1\" SchemaMinorVersion=\"1\" SchemaSubMinorVersion=\"0\" "
      << "MajorVersion=\"1\" MinorVersion=\"0\" SubMinorVersion=\"0\" ToolTip=\"Chromosphere camera simulator\" "
      << "ProductGuid=\"6a1c0d2e-4c57-4e0b-9a51-6368726f6d6f\" VersionGuid=\"6a1c0d2e-4c57-4e0b-9a51-000000000001\" "
      << "xmlns=\"http://www.genicam.org/GenApi/Version_1_1\" "
      << "xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
      << "xsi:schemaLocation=\"http://www.genicam.org/GenApi/Version_1_1 GenApiSchema_Version_1_1.xsd\">\n";
  xml << category("Root",
                  {"DeviceControl", "ImageFormatControl", "AcquisitionControl", "AnalogControl", "ChunkDataControl"});
  xml << category("DeviceControl", {"DeviceVendorName", "DeviceModelName", "DeviceVersion", "DeviceManufacturerInfo",
                                    "DeviceSerialNumber", "DeviceID", "DeviceUserID"});
  xml << string_reg("DeviceVendorName", 0x48, 32, "RO") << string_reg("DeviceModelName", 0x68, 32, "RO")
      << string_reg("DeviceVersion", 0x88, 32, "RO") << string_reg("DeviceManufacturerInfo", 0xA8, 48, "RO")
      << string_reg("DeviceSerialNumber", 0xD8, 16, "RO") << string_reg("DeviceID", 0xD8, 16, "RO")
      << string_reg("DeviceUserID", 0xE8, 16, "RW");

  xml << category("ImageFormatControl", {"SensorWidth", "SensorHeight", "OffsetX", "OffsetY", "Width", "Height",
                                         "PixelFormat", "PayloadSize"});
  xml << integer("SensorWidth", "SensorWidthRegister", "", "") << int_reg("SensorWidthRegister", kSensorWidth, "RO")
      << integer("SensorHeight", "SensorHeightRegister", "", "")
      << int_reg("SensorHeightRegister", kSensorHeight, "RO")
      << integer("OffsetX", "OffsetXRegister", "0", "SensorWidth") << int_reg("OffsetXRegister", kOffsetX, "RW")
      << integer("OffsetY", "OffsetYRegister", "0", "SensorHeight") << int_reg("OffsetYRegister", kOffsetY, "RW")
      << integer("Width", "WidthRegister", "1", "SensorWidth") << int_reg("WidthRegister", kWidth, "RW")
      << integer("Height", "HeightRegister", "1", "SensorHeight") << int_reg("HeightRegister", kHeight, "RW");
  const auto code = [](drivers::PixelFormat format) { return drivers::pixel_format_info(format).pfnc_code; };
  using drivers::PixelFormat;
  xml << enumeration("PixelFormat", "PixelFormatRegister",
                     {{"Mono8", code(PixelFormat::kMono8)},
                      {"Mono12", code(PixelFormat::kMono12)},
                      {"Mono16", code(PixelFormat::kMono16)},
                      {"BayerRG8", code(PixelFormat::kBayerRG8)},
                      {"BayerRG12", code(PixelFormat::kBayerRG12)},
                      {"BayerRG16", code(PixelFormat::kBayerRG16)},
                      {"RGB8", code(PixelFormat::kRgb8)}})
      << int_reg("PixelFormatRegister", kPixelFormat, "RW");
  xml << "  <IntSwissKnife Name=\"PayloadSize\" NameSpace=\"Standard\">\n"
         "    <pVariable Name=\"WIDTH\">Width</pVariable>\n    <pVariable Name=\"HEIGHT\">Height</pVariable>\n"
         "    <pVariable Name=\"PIXELFORMAT\">PixelFormat</pVariable>\n"
         "    <pVariable Name=\"CHUNKMODE\">ChunkModeActiveRegister</pVariable>\n"
         "    <pVariable Name=\"CHUNKENABLE\">ChunkEnableRegister</pVariable>\n"
         "    <Formula>WIDTH * HEIGHT * ((PIXELFORMAT&gt;&gt;16)&amp;0xFF) / 8 + CHUNKMODE * CHUNKENABLE * " +
             std::to_string(kChunkOverheadBytes) + "</Formula>\n"
         "  </IntSwissKnife>\n";

  xml << category("AcquisitionControl",
                  {"AcquisitionMode", "AcquisitionStart", "AcquisitionStop", "AcquisitionFrameRate", "TriggerSelector",
                   "TriggerMode", "TriggerSource", "TriggerActivation", "TriggerSoftware", "ExposureTime"});
  xml << enumeration("AcquisitionMode", "AcquisitionModeRegister",
                     {{"Continuous", kModeContinuous}, {"SingleFrame", kModeSingleFrame}})
      << int_reg("AcquisitionModeRegister", kAcquisitionMode, "RW");
  xml << command("AcquisitionStart", "AcquisitionStartRegister")
      << int_reg("AcquisitionStartRegister", kAcquisitionStart, "WO")
      << command("AcquisitionStop", "AcquisitionStopRegister")
      << int_reg("AcquisitionStopRegister", kAcquisitionStop, "WO");
  xml << scaled_float("AcquisitionFrameRate", "AcquisitionFramePeriodRegister", "1000000 / FROM", "1000000 / TO",
                      "0.1", "1000.0", "Hz")
      << int_reg("AcquisitionFramePeriodRegister", kFramePeriodUs, "RW");
  xml << "  <Enumeration Name=\"TriggerSelector\" NameSpace=\"Standard\">\n"
         "    <EnumEntry Name=\"FrameStart\" NameSpace=\"Standard\">\n      <Value>0</Value>\n    </EnumEntry>\n"
         "    <pValue>TriggerSelectorValue</pValue>\n  </Enumeration>\n"
         "  <Integer Name=\"TriggerSelectorValue\" NameSpace=\"Custom\">\n    <Value>0</Value>\n  </Integer>\n";
  xml << enumeration("TriggerMode", "TriggerModeRegister", {{"Off", 0}, {"On", 1}})
      << int_reg("TriggerModeRegister", kTriggerMode, "RW")
      << enumeration("TriggerSource", "TriggerSourceRegister", {{"Line0", kSourceLine0}, {"Software", kSourceSoftware}})
      << int_reg("TriggerSourceRegister", kTriggerSource, "RW")
      << enumeration("TriggerActivation", "TriggerActivationRegister", {{"RisingEdge", 0}})
      << int_reg("TriggerActivationRegister", kTriggerActivation, "RW")
      << command("TriggerSoftware", "TriggerSoftwareRegister")
      << int_reg("TriggerSoftwareRegister", kTriggerSoftware, "WO");
  xml << scaled_float("ExposureTime", "ExposureTimeRegister", "FROM", "TO", "10.0", "10000000.0", "us")
      << int_reg("ExposureTimeRegister", kExposureUs, "RW");

  xml << category("AnalogControl", {"Gain"});
  xml << scaled_float("Gain", "GainRegister", "FROM * 100", "TO / 100", "0.0", "24.0", "dB")
      << int_reg("GainRegister", kGainCentiDb, "RW");

  // Chunk data: the camera's count of FrameStart triggers since AcquisitionStart.
  xml << category("ChunkDataControl", {"ChunkModeActive", "ChunkSelector", "ChunkEnable", "ChunkTriggerCount"});
  xml << boolean("ChunkModeActive", "ChunkModeActiveRegister") << int_reg("ChunkModeActiveRegister", kChunkModeActive, "RW")
      << enumeration("ChunkSelector", "ChunkSelectorRegister", {{"TriggerCount", 0}})
      << int_reg("ChunkSelectorRegister", kChunkSelector, "RW") << boolean("ChunkEnable", "ChunkEnableRegister")
      << int_reg("ChunkEnableRegister", kChunkEnable, "RW");
  xml << "  <Integer Name=\"ChunkTriggerCount\" NameSpace=\"Custom\">\n    <pValue>ChunkTriggerCountRegister</pValue>\n"
         "  </Integer>\n"
         "  <IntReg Name=\"ChunkTriggerCountRegister\" NameSpace=\"Custom\">\n    <Address>0x0</Address>\n"
         "    <Length>" << kTriggerCountChunkBytes << "</Length>\n    <AccessMode>RO</AccessMode>\n"
         "    <pPort>TriggerCountChunkPort</pPort>\n    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n"
         "  </IntReg>\n"
         "  <Port Name=\"TriggerCountChunkPort\" NameSpace=\"Custom\">\n    <ChunkID>" << std::hex
      << kTriggerCountChunkId << std::dec << "</ChunkID>\n  </Port>\n";

  xml << "  <Port Name=\"Device\" NameSpace=\"Standard\">\n  </Port>\n</RegisterDescription>\n";
  return xml.str();
}

}  // namespace chromo::simulators::camera_registers
